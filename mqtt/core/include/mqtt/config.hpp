// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt's configuration: read and validated once at start-up into an immutable struct.
// A bad key is one line that names it (the settings library's key tables, lib/settings).
#pragma once

#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "settings/reference.hpp"

namespace drivebus::mqtt {

using Duration = std::chrono::nanoseconds;

struct TlsConfig {
    std::filesystem::path cafile;    // the broker's CA: TLS is on when set
    std::filesystem::path certfile;  // client certificate (with keyfile), optional
    std::filesystem::path keyfile;
};

struct BrokerConfig {
    std::string host = "localhost";
    std::uint16_t port = 1883;
    std::string client_id;  // empty: "drivebus-mqtt-<node>"
    Duration keepalive = std::chrono::seconds(30);
    std::string username;
    std::filesystem::path password_file;  // the password, read at start-up (first line)
    std::optional<TlsConfig> tls;
    Duration reconnect_min = std::chrono::seconds(1);
    Duration reconnect_max = std::chrono::seconds(30);
};

struct Limits {
    std::size_t command_queue = 32;      // commands waiting to be carried out; more: refused at once
    std::size_t max_payload = 4096;      // bytes of a command; larger: refused
    std::size_t results_in_flight = 64;  // QoS 1 results the broker has not acknowledged; more: dropped
    // The oldest a command may be when it acts (its max_age may shorten it): older, it is
    // refused as expired. Its age counts from its sent_at when it gives one, else from its arrival.
    Duration max_command_age = std::chrono::seconds(10);
};

struct DriveSettings {
    std::string name;
    Duration period = std::chrono::seconds(10);  // publish at least this often
    double deadband = 0.0;                       // engineering units: smaller changes wait for the period
    bool commands = false;                       // take commands on .../set
};

struct BusSettings {
    std::string name;
    Duration period = std::chrono::seconds(10);
    double deadband = 0.0;
    std::vector<DriveSettings> drives;  // those listed; the others get the bus's values, no commands

    // The settings of `drive`: its own entry, or the bus's defaults.
    [[nodiscard]] DriveSettings drive(std::string_view drive) const;
};

struct Config {
    std::string node;  // the topic level after "drivebus/"
    BrokerConfig broker;
    Limits limits;
    std::vector<BusSettings> buses;
    std::string password;  // read from broker.password_file

    [[nodiscard]] std::string client_id() const {
        return broker.client_id.empty() ? "drivebus-mqtt-" + node : broker.client_id;
    }
};

struct ConfigError {
    std::string message;  // one line: "bridge.toml: broker: unknown key 'hots'"
};

// The keys of each table as the reader's tables state them: what docs/mqtt.md describes, and
// what a test checks it against.
[[nodiscard]] std::vector<settings::SectionReference> reference();

// Parses configuration text; `source` names it in errors; `hostname` is the node's default.
// Files named (the password file) are read relative to the working directory.
[[nodiscard]] std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source,
                                                              std::string_view hostname);
// Reads and parses a file.
[[nodiscard]] std::expected<Config, ConfigError> load_config(const std::filesystem::path& file,
                                                             std::string_view hostname);

// Node, bus and drive names become topic levels: letters, digits, '_', '-', '.', at most 64.
[[nodiscard]] bool valid_level(std::string_view name) noexcept;

}  // namespace drivebus::mqtt
