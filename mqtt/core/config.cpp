// SPDX-License-Identifier: Apache-2.0
#include "mqtt/config.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <sstream>

#include "settings/keys.hpp"
#include "settings/reader.hpp"

namespace drivebus::mqtt {
namespace {

using settings::Errors;
using settings::in_quotes;
using settings::Key;
using settings::Need;
using settings::Section;
using settings::words;
using namespace std::chrono_literals;

constexpr std::uintmax_t kMaxConfigSize = 1 << 20;
constexpr std::string_view kLevelRule = "letters, digits, '_', '-', '.', at most 64";

// A topic level: the node, a bus or a drive.
template <typename T, std::string T::* Field>
void read_level(Section& s, const toml::table& /*table*/, const Key<T>& key, T& out) {
    if (auto name = s.string(key.name, key.need)) {
        if (!valid_level(*name)) {
            s.fail(std::string(key.name) + " " + in_quotes(*name) + " is not a topic level (" +
                   std::string(kLevelRule) + ")");
            return;
        }
        out.*Field = std::move(*name);
    }
}

// Engineering units: 0 or more.
template <typename T, double T::* Field>
void read_deadband(Section& s, const toml::table& /*table*/, const Key<T>& key, T& out) {
    if (const auto value = s.number(key.name)) {
        if (!(*value >= 0.0 && *value <= 1e9)) {
            s.fail(std::string(key.name) + " " + settings::number_text(*value) +
                   (*value < 0.0 ? " is below 0" : " is above 1000000000"));
            return;
        }
        out.*Field = *value;
    }
}

// A text of `lo`-`hi` characters.
template <typename T, std::string T::* Field, std::size_t lo, std::size_t hi>
void read_sized(Section& s, const toml::table& /*table*/, const Key<T>& key, T& out) {
    if (auto text = s.string(key.name, key.need)) {
        if (text->size() < lo || text->size() > hi) {
            s.fail(std::string(key.name) + " " + in_quotes(*text) + " is not " + std::to_string(lo) + "-" +
                   std::to_string(hi) + " characters");
            return;
        }
        out.*Field = std::move(*text);
    }
}

struct Root {
    std::string node;
};
using RootKeys = settings::Keys<Root>;
using BrokerKeys = settings::Keys<BrokerConfig>;
using TlsKeys = settings::Keys<TlsConfig>;
using LimitKeys = settings::Keys<Limits>;
using BusKeys = settings::Keys<BusSettings>;
using DriveKeys = settings::Keys<DriveSettings>;

constexpr std::array<Key<Root>, 1> kRootKeys = {
    RootKeys::custom(
        "node", "string", Need::Optional, words(kLevelRule), read_level<Root, &Root::node>,
        [](const Key<Root>& /*key*/) { return std::string("the host name"); }, "the topic level after drivebus/"),
};

constexpr std::array<Key<BrokerConfig>, 8> kBrokerKeys = {
    BrokerKeys::custom("host", "string", Need::Optional, words("1-255 characters"),
                       read_sized<BrokerConfig, &BrokerConfig::host, 1, 255>, BrokerKeys::shown<&BrokerConfig::host>,
                       "the broker"),
    BrokerKeys::integer<&BrokerConfig::port>("port", 1, 65535, "the broker's port (8883 is the usual TLS port)"),
    BrokerKeys::custom(
        "client_id", "string", Need::Optional, words("1-128 characters"),
        read_sized<BrokerConfig, &BrokerConfig::client_id, 1, 128>,
        [](const Key<BrokerConfig>& /*key*/) { return std::string("\"drivebus-mqtt-<node>\""); },
        "the client id, unique on the broker"),
    BrokerKeys::duration<&BrokerConfig::keepalive>("keepalive", 5s, 3600s, "the MQTT keep-alive"),
    BrokerKeys::text<&BrokerConfig::username>("username", {}, "the user name"),
    BrokerKeys::path<&BrokerConfig::password_file>("password_file", words("a file's path"),
                                                   "the password: the file's first line"),
    BrokerKeys::duration<&BrokerConfig::reconnect_min>("reconnect_min", 100ms, 60s, "the back-off's first delay"),
    BrokerKeys::duration<&BrokerConfig::reconnect_max>("reconnect_max", 100ms, 3600s, "the back-off's longest delay"),
};

constexpr std::array<Key<TlsConfig>, 3> kTlsKeys = {
    TlsKeys::path<&TlsConfig::cafile>("cafile", words("a file's path"), "the CA that signed the broker's certificate",
                                      Need::Required),
    TlsKeys::path<&TlsConfig::certfile>("certfile", words("a file's path"), "a client certificate"),
    TlsKeys::path<&TlsConfig::keyfile>("keyfile", words("a file's path"), "its key"),
};

constexpr std::array<Key<Limits>, 4> kLimitKeys = {
    LimitKeys::integer<&Limits::command_queue>("command_queue", 1, 4096, "commands waiting to be carried out"),
    LimitKeys::integer<&Limits::max_payload>("max_payload", 64, 1 << 20, "bytes of a command"),
    LimitKeys::integer<&Limits::results_in_flight>("results_in_flight", 1, 65535,
                                                   "QoS 1 results the broker has not acknowledged"),
    LimitKeys::duration<&Limits::max_command_age>("max_command_age", 100ms, 24h,
                                                  "the oldest a command may be when it acts"),
};

constexpr std::array<Key<BusSettings>, 3> kBusKeys = {
    BusKeys::custom("name", "string", Need::Required, words(kLevelRule), read_level<BusSettings, &BusSettings::name>,
                    nullptr, "a bus of drivebusd"),
    BusKeys::duration<&BusSettings::period>("period", 100ms, 24h, "each state at least this often"),
    BusKeys::custom("deadband", "number", Need::Optional, settings::integers(0, 1'000'000'000),
                    read_deadband<BusSettings, &BusSettings::deadband>, BusKeys::shown<&BusSettings::deadband>,
                    "engineering units: smaller changes wait for the period"),
};

// A drive's period and deadband default to its bus's.
std::string shown_the_bus(const Key<DriveSettings>& /*key*/) {
    return "the bus's";
}

constexpr std::array<Key<DriveSettings>, 4> kDriveKeys = {
    DriveKeys::custom("name", "string", Need::Required, words(kLevelRule),
                      read_level<DriveSettings, &DriveSettings::name>, nullptr, "a drive of that bus"),
    DriveKeys::custom("period", "duration", Need::Optional, settings::durations(100ms, 24h),
                      DriveKeys::read_duration<&DriveSettings::period>, shown_the_bus, "its state at least this often"),
    DriveKeys::custom("deadband", "number", Need::Optional, settings::integers(0, 1'000'000'000),
                      read_deadband<DriveSettings, &DriveSettings::deadband>, shown_the_bus,
                      "engineering units: smaller changes wait for the period"),
    DriveKeys::boolean<&DriveSettings::commands>("commands", "take commands on its set topic"),
};

BrokerConfig read_broker(const toml::table& table, Errors& errors) {
    Section s(table, "broker", errors);
    settings::allow_only(s, table, {"tls"}, kBrokerKeys);
    BrokerConfig b;
    settings::read_keys(s, table, kBrokerKeys, b);
    if (b.reconnect_max < b.reconnect_min) {
        s.fail("reconnect_max " + settings::duration_text(b.reconnect_max) + " is below reconnect_min " +
               settings::duration_text(b.reconnect_min));
    }
    if (!b.password_file.empty() && b.username.empty()) {
        s.fail("password_file needs username");
    }
    if (const auto* tls = s.table("tls")) {
        Section t(*tls, "broker.tls", errors);
        settings::allow_only(t, *tls, {}, kTlsKeys);
        settings::read_keys(t, *tls, kTlsKeys, b.tls.emplace());
        if (b.tls->certfile.empty() != b.tls->keyfile.empty()) {
            t.fail("certfile and keyfile go together");
        }
    }
    return b;
}

Limits read_limits(const toml::table& table, Errors& errors) {
    Section s(table, "limits", errors);
    settings::allow_only(s, table, {}, kLimitKeys);
    Limits l;
    settings::read_keys(s, table, kLimitKeys, l);
    return l;
}

DriveSettings read_drive(const toml::table& table, std::size_t index, const BusSettings& bus, Errors& errors) {
    Section s(table, "bus '" + bus.name + "': drive #" + std::to_string(index + 1), errors);
    settings::allow_only(s, table, {}, kDriveKeys);
    DriveSettings d{.name = {}, .period = bus.period, .deadband = bus.deadband, .commands = false};
    for (const auto& key : kDriveKeys) {
        key.read(s, table, key, d);
        if (key.name == "name" && !d.name.empty()) {
            s.rename("bus '" + bus.name + "': drive '" + d.name + "'");  // the errors that follow name it
        }
    }
    return d;
}

BusSettings read_bus(const toml::table& table, std::size_t index, Errors& errors) {
    Section s(table, "bus #" + std::to_string(index + 1), errors);
    settings::allow_only(s, table, {"drive"}, kBusKeys);
    BusSettings b;
    for (const auto& key : kBusKeys) {
        key.read(s, table, key, b);
        if (key.name == "name" && !b.name.empty()) {
            s.rename("bus '" + b.name + "'");
        }
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

std::vector<settings::SectionReference> reference() {
    return {settings::described("top level", kRootKeys),   settings::described("[broker]", kBrokerKeys),
            settings::described("[broker.tls]", kTlsKeys), settings::described("[limits]", kLimitKeys),
            settings::described("[[bus]]", kBusKeys),      settings::described("[[bus.drive]]", kDriveKeys)};
}

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
    auto root = settings::parse_toml(text, source);
    if (!root) {
        return std::unexpected(ConfigError{std::move(root.error())});
    }
    Errors errors(source);
    Section s(*root, "", errors);
    settings::allow_only(s, *root, {"broker", "limits", "bus"}, kRootKeys);
    Config c;
    Root top{.node = std::string(hostname)};
    const bool named = root->contains("node");
    settings::read_keys(s, *root, kRootKeys, top);
    c.node = std::move(top.node);
    if (!named && !valid_level(c.node)) {
        s.fail("node: the host name " + in_quotes(c.node) + " is not a topic level (" + std::string(kLevelRule) +
               "): set node");
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
