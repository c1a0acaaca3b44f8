// SPDX-License-Identifier: Apache-2.0
// drivebus-gateway's configuration (docs/gateway.md): read once at start into this struct, every
// key checked against its range; an error is one line that names the file and the key.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "gateway/network.hpp"
#include "settings/reference.hpp"

namespace drivebus::gateway {

using Milliseconds = std::chrono::milliseconds;

// A Modbus TCP unit id and the drive it reaches.
struct UnitRoute {
    std::uint8_t unit = 0;
    std::string bus;    // empty: Config::bus
    std::string drive;  // a drive's name, or its address ("3")
};

struct Config {
    Endpoint listen{"127.0.0.1", 502};
    // The bus whose drives are reached by unit id = address, and that [[unit]] tables name by
    // default. Empty: the only bus drivebusd announces.
    std::string bus;
    // Explicit routes; when there are none, each drive of `bus` is unit id = its address.
    std::vector<UnitRoute> units;
    // The oldest polled value a read is answered with; older, the read goes to the drive.
    Milliseconds max_age{1000};
    // How long a request sent to drivebusd may take (its queue and retries included).
    Milliseconds request_timeout{2000};
    // A connection that sends no request for this long is closed (0: never).
    Milliseconds idle_timeout{60000};
    std::size_t max_connections = 32;
    // Requests read ahead from one connection; past it, the gateway reads no more from it until
    // it has answered (the client waits, no other client does).
    std::size_t max_pipelined = 16;
    // Requests the gateway has under way with drivebusd at once.
    std::size_t workers = 4;
    std::vector<Network> allow_from;  // who may connect; empty: anyone who reaches `listen`
    std::vector<Network> write_from;  // who may write (FC06, FC16); empty: nobody (read-only)
};

struct ConfigError {
    std::string message;  // one line: "gateway.toml: gateway: max_age: ..."
};

// The keys of [gateway] and [[unit]] as the reader's tables state them: what docs/gateway.md
// and drivebus-gateway(8) describe, and what a test checks them against.
[[nodiscard]] std::vector<settings::SectionReference> reference();

[[nodiscard]] std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source);
[[nodiscard]] std::expected<Config, ConfigError> load_config(const std::filesystem::path& file);

}  // namespace drivebus::gateway
