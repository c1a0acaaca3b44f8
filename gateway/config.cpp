// SPDX-License-Identifier: Apache-2.0
#include "gateway/config.hpp"

#include <array>
#include <chrono>
#include <utility>

#include "settings/keys.hpp"
#include "settings/reader.hpp"

namespace drivebus::gateway {
namespace {

using settings::Errors;
using settings::Key;
using settings::Need;
using settings::Section;
using settings::words;
using namespace std::chrono_literals;

using GatewayKeys = settings::Keys<Config>;
using UnitKeys = settings::Keys<UnitRoute>;

constexpr std::uintmax_t kMaxFileSize = 1 << 20;

void read_listen(Section& s, const toml::table& /*table*/, const Key<Config>& key, Config& c) {
    if (const auto listen = s.string(key.name)) {
        if (auto endpoint = parse_endpoint(*listen)) {
            c.listen = std::move(*endpoint);
        } else {
            s.fail(std::string(key.name) + ": " + endpoint.error());
        }
    }
}

std::string shown_listen(const Key<Config>& /*key*/) {
    const Endpoint listen = Config{}.listen;
    return "\"" + (listen.host.empty() ? std::string("*") : listen.host) + ":" + std::to_string(listen.port) + "\"";
}

template <std::vector<Network> Config::* List>
void read_networks(Section& s, const toml::table& /*table*/, const Key<Config>& key, Config& c) {
    const auto texts = s.strings(key.name);
    if (!texts) {
        return;
    }
    auto& out = c.*List;
    out.clear();
    for (const auto& text : *texts) {
        auto network = Network::parse(text);
        if (!network) {
            s.fail(std::string(key.name) + ": " + network.error());
            return;
        }
        out.push_back(std::move(*network));
    }
}

// Both lists are empty by default.
std::string shown_none(const Key<Config>& /*key*/) {
    return "none";
}

constexpr std::array<Key<Config>, 10> kGatewayKeys = {
    GatewayKeys::custom("listen", "string", Need::Optional, words("HOST:PORT, [V6]:PORT or *:PORT"), read_listen,
                        shown_listen, "where Modbus TCP clients connect"),
    GatewayKeys::text<&Config::bus>("bus", words("a bus name"),
                                    "the bus whose drives answer to their address as unit id; \"\": the only one"),
    GatewayKeys::duration<&Config::max_age>("max_age", 0ms, 1h, "the oldest polled value served from the snapshot"),
    GatewayKeys::duration<&Config::request_timeout>("request_timeout", 50ms, 60s,
                                                    "how long a request to drivebusd may take"),
    GatewayKeys::duration<&Config::idle_timeout>("idle_timeout", 0ms, 24h,
                                                 "a connection silent this long is closed; 0: never"),
    GatewayKeys::integer<&Config::max_connections>("max_connections", 1, 1024, "connections open at once"),
    GatewayKeys::integer<&Config::max_pipelined>("max_pipelined", 1, 256, "requests read ahead from one connection"),
    GatewayKeys::integer<&Config::workers>("workers", 1, 64, "requests under way with drivebusd at once"),
    GatewayKeys::custom("allow_from", "array of strings", Need::Optional, words("networks"),
                        read_networks<&Config::allow_from>, shown_none, "sources that may connect; none: anyone"),
    GatewayKeys::custom("write_from", "array of strings", Need::Optional, words("networks"),
                        read_networks<&Config::write_from>, shown_none, "sources that may write; none: nobody"),
};

constexpr std::array<Key<UnitRoute>, 3> kUnitKeys = {
    UnitKeys::integer<&UnitRoute::unit>("id", 1, 247, "the Modbus TCP unit id", Need::Required),
    UnitKeys::text<&UnitRoute::bus>("bus", words("a bus name"), "the drive's bus; \"\": gateway.bus"),
    UnitKeys::text<&UnitRoute::drive>("drive", words("a drive's name or address"), "the drive the unit id reaches",
                                      Need::Required),
};

void read_units(Section& root, Errors& errors, Config& c) {
    const auto tables = root.tables("unit");
    for (std::size_t i = 0; i < tables.size(); ++i) {
        Section s(*tables[i], "unit #" + std::to_string(i + 1), errors);
        settings::allow_only(s, *tables[i], {}, kUnitKeys);
        UnitRoute route;
        for (const auto& key : kUnitKeys) {
            key.read(s, *tables[i], key, route);
            if (key.name == "id" && route.unit != 0) {
                s.rename("unit " + std::to_string(route.unit));  // the errors that follow name it
            }
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

std::vector<settings::SectionReference> reference() {
    return {settings::described("[gateway]", kGatewayKeys), settings::described("[[unit]]", kUnitKeys)};
}

std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source) {
    auto root_table = settings::parse_toml(text, source);
    if (!root_table) {
        return std::unexpected(ConfigError{std::move(root_table.error())});
    }
    Errors errors(source);
    Section root(*root_table, "", errors);
    root.allow_only({"gateway", "unit"});
    Config c;
    if (const auto* table = root.table("gateway")) {
        Section s(*table, "gateway", errors);
        settings::allow_only(s, *table, {}, kGatewayKeys);
        settings::read_keys(s, *table, kGatewayKeys, c);
    }
    read_units(root, errors, c);
    if (errors.any()) {
        return std::unexpected(ConfigError{errors.message()});
    }
    return c;
}

std::expected<Config, ConfigError> load_config(const std::filesystem::path& file) {
    const auto text = settings::read_small_file(file, kMaxFileSize, "a configuration");
    if (!text) {
        return std::unexpected(ConfigError{text.error()});
    }
    return parse_config(*text, file.string());
}

}  // namespace drivebus::gateway
