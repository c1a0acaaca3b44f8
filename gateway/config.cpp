// SPDX-License-Identifier: Apache-2.0
#include "gateway/config.hpp"

#include <charconv>
#include <optional>

#include "duration/duration.hpp"
#include "profile/toml_reader.hpp"

namespace drivebus::gateway {
namespace {

using profile_detail::Errors;
using profile_detail::Need;
using profile_detail::Section;

constexpr std::uintmax_t kMaxFileSize = 1 << 20;

std::optional<Milliseconds> duration(Section& s, std::string_view key, Milliseconds lo, Milliseconds hi) {
    const auto text = s.string(key);
    if (!text) {
        return std::nullopt;
    }
    const auto parsed = parse_duration(*text);
    if (!parsed) {
        s.fail(std::string(key) + ": " + parsed.error());
        return std::nullopt;
    }
    const auto value = std::chrono::duration_cast<Milliseconds>(*parsed);
    if (value < lo || value > hi || (value.count() == 0 && parsed->count() != 0)) {
        s.fail(std::string(key) + ": '" + *text + "' is outside " + std::to_string(lo.count()) + "ms.." +
               std::to_string(hi.count()) + "ms");
        return std::nullopt;
    }
    return value;
}

std::vector<Network> networks(Section& s, std::string_view key) {
    std::vector<Network> out;
    const auto texts = s.strings(key);
    if (!texts) {
        return out;
    }
    for (const auto& t : *texts) {
        auto n = Network::parse(t);
        if (!n) {
            s.fail(std::string(key) + ": " + n.error());
            continue;
        }
        out.push_back(std::move(*n));
    }
    return out;
}

void read_gateway(Section& s, Config& c) {
    s.allow_only({"listen", "bus", "max_age", "request_timeout", "idle_timeout", "max_connections", "max_pipelined",
                  "workers", "allow_from", "write_from"});
    if (const auto listen = s.string("listen")) {
        auto e = parse_endpoint(*listen);
        if (e) {
            c.listen = *e;
        } else {
            s.fail("listen: " + e.error());
        }
    }
    if (auto bus = s.string("bus")) {
        c.bus = std::move(*bus);
    }
    if (const auto v = duration(s, "max_age", Milliseconds(0), Milliseconds(3'600'000))) {
        c.max_age = *v;
    }
    if (const auto v = duration(s, "request_timeout", Milliseconds(50), Milliseconds(60'000))) {
        c.request_timeout = *v;
    }
    if (const auto v = duration(s, "idle_timeout", Milliseconds(0), Milliseconds(86'400'000))) {
        c.idle_timeout = *v;
    }
    if (const auto v = s.integer("max_connections", 1, 1024)) {
        c.max_connections = static_cast<std::size_t>(*v);
    }
    if (const auto v = s.integer("max_pipelined", 1, 256)) {
        c.max_pipelined = static_cast<std::size_t>(*v);
    }
    if (const auto v = s.integer("workers", 1, 64)) {
        c.workers = static_cast<std::size_t>(*v);
    }
    c.allow_from = networks(s, "allow_from");
    c.write_from = networks(s, "write_from");
}

void read_units(Section& root, Errors& errors, Config& c) {
    const auto tables = root.tables("unit");
    for (std::size_t i = 0; i < tables.size(); ++i) {
        Section s(*tables[i], "unit #" + std::to_string(i + 1), errors);
        s.allow_only({"id", "bus", "drive"});
        UnitRoute route;
        if (const auto id = s.integer("id", 1, 247, Need::Required)) {
            route.unit = static_cast<std::uint8_t>(*id);
            s.rename("unit " + std::to_string(*id));
        }
        if (auto bus = s.string("bus")) {
            route.bus = std::move(*bus);
        }
        if (auto drive = s.string("drive", Need::Required)) {
            route.drive = std::move(*drive);
        }
        for (const auto& other : c.units) {
            if (other.unit == route.unit && route.unit != 0) {
                s.fail("id: unit " + std::to_string(route.unit) + " is routed twice");
            }
        }
        c.units.push_back(std::move(route));
    }
}

}  // namespace

std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source) {
    toml::table root_table;
    try {
        root_table = toml::parse(text, source);
    } catch (const toml::parse_error& e) {
        std::string line = std::string(source) + ": line " + std::to_string(e.source().begin.line) + ": ";
        for (const char ch : e.description()) {
            line += (ch == '\n' || ch == '\r') ? ' ' : ch;
        }
        return std::unexpected(ConfigError{std::move(line)});
    }
    Errors errors(source);
    Section root(root_table, "", errors);
    root.allow_only({"gateway", "unit"});
    Config c;
    if (const auto* table = root.table("gateway")) {
        Section s(*table, "gateway", errors);
        read_gateway(s, c);
    }
    read_units(root, errors, c);
    if (errors.any()) {
        return std::unexpected(ConfigError{errors.error().message});
    }
    return c;
}

std::expected<Config, ConfigError> load_config(const std::filesystem::path& file) {
    const auto text = profile_detail::read_small_file(file, kMaxFileSize, "a configuration");
    if (!text) {
        return std::unexpected(ConfigError{text.error()});
    }
    return parse_config(*text, file.string());
}

}  // namespace drivebus::gateway
