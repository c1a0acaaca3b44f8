// SPDX-License-Identifier: Apache-2.0
#include "mqtt/config.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "duration/duration.hpp"
#include "settings/reader.hpp"

namespace drivebus::mqtt {
namespace {

using settings::Errors;
using settings::in_quotes;
using settings::Need;
using settings::Section;

constexpr std::uintmax_t kMaxConfigSize = 1 << 20;

std::optional<Duration> duration(Section& s, std::string_view key, Duration lo, Duration hi) {
    const auto text = s.string(key);
    if (!text) {
        return std::nullopt;
    }
    const auto d = parse_duration(*text);
    if (!d) {
        s.fail(std::string(key) + ": " + in_quotes(*text) + " " + d.error());
        return std::nullopt;
    }
    if (*d < lo || *d > hi) {
        s.fail(std::string(key) + ": " + in_quotes(*text) + " is outside " +
               std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(lo).count()) + "ms-" +
               std::to_string(std::chrono::duration_cast<std::chrono::seconds>(hi).count()) + "s");
        return std::nullopt;
    }
    return *d;
}

std::optional<double> deadband(Section& s) {
    const auto value = s.number("deadband");
    if (value && (*value < 0.0 || *value > 1e9)) {
        s.fail("deadband: must be 0 or more");
        return std::nullopt;
    }
    return value;
}

void read_name(Section& s, std::string& out, std::string_view what) {
    if (const auto name = s.string("name", Need::Required)) {
        if (!valid_level(*name)) {
            s.fail("name: " + in_quotes(*name) + " is not a valid " + std::string(what) +
                   " name (letters, digits, '_', '-', '.', at most 64)");
            return;
        }
        out = *name;
    }
}

BrokerConfig read_broker(const toml::table& table, Errors& errors) {
    Section s(table, "broker", errors);
    s.allow_only({"host", "port", "client_id", "keepalive", "username", "password_file", "reconnect_min",
                  "reconnect_max", "tls"});
    BrokerConfig b;
    if (auto host = s.string("host")) {
        if (host->empty()) {
            s.fail("host: empty");
        }
        b.host = *host;
    }
    if (auto port = s.integer("port", 1, 65535)) {
        b.port = static_cast<std::uint16_t>(*port);
    }
    if (auto id = s.string("client_id")) {
        if (id->empty() || id->size() > 128) {
            s.fail("client_id: must be 1-128 characters");
        }
        b.client_id = *id;
    }
    if (auto d = duration(s, "keepalive", std::chrono::seconds(5), std::chrono::seconds(3600))) {
        b.keepalive = *d;
    }
    if (auto user = s.string("username")) {
        b.username = *user;
    }
    if (auto file = s.string("password_file")) {
        b.password_file = *file;
    }
    if (auto d = duration(s, "reconnect_min", std::chrono::milliseconds(100), std::chrono::seconds(60))) {
        b.reconnect_min = *d;
    }
    if (auto d = duration(s, "reconnect_max", std::chrono::milliseconds(100), std::chrono::seconds(3600))) {
        b.reconnect_max = *d;
    }
    if (b.reconnect_max < b.reconnect_min) {
        s.fail("reconnect_max: shorter than reconnect_min");
    }
    if (!b.password_file.empty() && b.username.empty()) {
        s.fail("password_file: needs username");
    }
    if (const auto* tls = s.table("tls")) {
        Section t(*tls, "broker.tls", errors);
        t.allow_only({"cafile", "certfile", "keyfile"});
        TlsConfig c;
        if (auto f = t.string("cafile", Need::Required)) {
            c.cafile = *f;
        }
        if (auto f = t.string("certfile")) {
            c.certfile = *f;
        }
        if (auto f = t.string("keyfile")) {
            c.keyfile = *f;
        }
        if (c.certfile.empty() != c.keyfile.empty()) {
            t.fail("certfile and keyfile go together");
        }
        b.tls = c;
    }
    return b;
}

Limits read_limits(const toml::table& table, Errors& errors) {
    Section s(table, "limits", errors);
    s.allow_only({"command_queue", "max_payload", "results_in_flight", "max_command_age"});
    Limits l;
    if (auto v = s.integer("command_queue", 1, 4096)) {
        l.command_queue = static_cast<std::size_t>(*v);
    }
    if (auto v = s.integer("max_payload", 64, 1 << 20)) {
        l.max_payload = static_cast<std::size_t>(*v);
    }
    if (auto v = s.integer("results_in_flight", 1, 65535)) {
        l.results_in_flight = static_cast<std::size_t>(*v);
    }
    if (auto d = duration(s, "max_command_age", std::chrono::milliseconds(100), std::chrono::hours(24))) {
        l.max_command_age = *d;
    }
    return l;
}

constexpr auto kShortestPeriod = std::chrono::milliseconds(100);
constexpr auto kLongestPeriod = std::chrono::hours(24);

DriveSettings read_drive(const toml::table& table, std::size_t index, const BusSettings& bus, Errors& errors) {
    Section s(table, "bus '" + bus.name + "': drive #" + std::to_string(index + 1), errors);
    s.allow_only({"name", "period", "deadband", "commands"});
    DriveSettings d{.name = {}, .period = bus.period, .deadband = bus.deadband, .commands = false};
    read_name(s, d.name, "drive");
    if (!d.name.empty()) {
        s.rename("bus '" + bus.name + "': drive '" + d.name + "'");
    }
    if (auto p = duration(s, "period", kShortestPeriod, kLongestPeriod)) {
        d.period = *p;
    }
    if (auto db = deadband(s)) {
        d.deadband = *db;
    }
    if (auto c = s.boolean("commands")) {
        d.commands = *c;
    }
    return d;
}

BusSettings read_bus(const toml::table& table, std::size_t index, Errors& errors) {
    Section s(table, "bus #" + std::to_string(index + 1), errors);
    s.allow_only({"name", "period", "deadband", "drive"});
    BusSettings b;
    read_name(s, b.name, "bus");
    if (!b.name.empty()) {
        s.rename("bus '" + b.name + "'");
    }
    if (auto p = duration(s, "period", kShortestPeriod, kLongestPeriod)) {
        b.period = *p;
    }
    if (auto db = deadband(s)) {
        b.deadband = *db;
    }
    const auto drives = s.tables("drive");
    for (std::size_t i = 0; i < drives.size(); ++i) {
        auto d = read_drive(*drives[i], i, b, errors);
        if (std::ranges::any_of(b.drives, [&](const DriveSettings& o) { return o.name == d.name; })) {
            s.fail("drive '" + d.name + "' listed twice");
        }
        b.drives.push_back(std::move(d));
    }
    return b;
}

}  // namespace

bool valid_level(std::string_view name) noexcept {
    return !name.empty() && name.size() <= 64 && std::ranges::all_of(name, [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
               c == '.';
    });
}

DriveSettings BusSettings::drive(std::string_view drive) const {
    for (const auto& d : drives) {
        if (d.name == drive) {
            return d;
        }
    }
    return DriveSettings{.name = std::string(drive), .period = period, .deadband = deadband, .commands = false};
}

std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source,
                                                std::string_view hostname) {
    toml::table root;
    try {
        root = toml::parse(text, source);
    } catch (const toml::parse_error& e) {
        return std::unexpected(ConfigError{std::string(source) + ":" + std::to_string(e.source().begin.line) + ": " +
                                           std::string(e.description())});
    }
    Errors errors(source);
    Section s(root, "", errors);
    s.allow_only({"node", "broker", "limits", "bus"});
    Config c;
    c.node = std::string(hostname);
    if (auto node = s.string("node")) {
        c.node = *node;
    }
    if (!valid_level(c.node)) {
        s.fail("node: " + in_quotes(c.node) +
               " is not a valid topic level (letters, digits, '_', '-', '.', at most 64): set node");
    }
    if (const auto* broker = s.table("broker")) {
        c.broker = read_broker(*broker, errors);
    }
    if (const auto* limits = s.table("limits")) {
        c.limits = read_limits(*limits, errors);
    }
    const auto buses = s.tables("bus");
    if (buses.empty()) {
        s.fail("no [[bus]]: name at least one bus to bridge");
    }
    for (std::size_t i = 0; i < buses.size(); ++i) {
        auto b = read_bus(*buses[i], i, errors);
        if (std::ranges::any_of(c.buses, [&](const BusSettings& o) { return o.name == b.name; })) {
            s.fail("bus '" + b.name + "' listed twice");
        }
        c.buses.push_back(std::move(b));
    }
    if (!errors.any() && !c.broker.password_file.empty()) {
        auto password = settings::read_small_file(c.broker.password_file, 4096, "password file");
        if (!password) {
            errors.add("broker", "password_file: " + password.error());
        } else {
            std::istringstream lines(*password);
            std::getline(lines, c.password);
            if (c.password.empty()) {
                errors.add("broker", "password_file: " + c.broker.password_file.string() + " holds no password");
            }
        }
    }
    if (errors.any()) {
        return std::unexpected(ConfigError{errors.message()});
    }
    return c;
}

std::expected<Config, ConfigError> load_config(const std::filesystem::path& file, std::string_view hostname) {
    auto text = settings::read_small_file(file, kMaxConfigSize, "configuration");
    if (!text) {
        return std::unexpected(ConfigError{text.error()});
    }
    return parse_config(*text, file.string(), hostname);
}

}  // namespace drivebus::mqtt
