// SPDX-License-Identifier: Apache-2.0
// drivebusd's configuration: parsed and validated once at start-up into this immutable
// struct. Nothing is opened before it is valid. See docs/configuration.md.
#pragma once

#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "drivebus/profile.hpp"
#include "master/bus_plan.hpp"
#include "rtu/timing.hpp"
#include "serial/options.hpp"

namespace drivebus::config {

enum class DirectionMode : std::uint8_t { Kernel, Gpio, Rts, None };

// What the master runs (master/bus_plan.hpp), as the configuration names it.
using master::Duration;
using master::EchoMode;
using master::LeaseFallback;
using master::PolledRegister;
using master::PollGroup;
using DriveConfig = master::DrivePlan;

// A bus: the line's settings and the plan the master runs on it.
struct BusConfig : master::BusPlan {
    std::filesystem::path device;
    DirectionMode direction = DirectionMode::None;
    serial::KernelRs485Options kernel;        // for DirectionMode::Kernel
    std::optional<serial::GpioOptions> gpio;  // required for DirectionMode::Gpio
    // Used when the kernel says it has no RS485 support: rts, none, or nullopt (fail).
    std::optional<DirectionMode> kernel_fallback;
    std::filesystem::path lock_dir;  // UUCP lock files; empty: none
    // Where the bus's lease record is kept (ipc/lease_record.hpp): a tmpfs, gone at boot.
    std::filesystem::path state_dir = "/run/drivebus";
    // Every drive silent this long while requests time out and the port is open: the port is
    // reopened (master/mute_watch.hpp). nullopt: never.
    std::optional<Duration> mute_reopen = std::chrono::seconds(10);
    // The bus's [[bus]] table as written (TOML, normalised): a reload restarts the buses whose
    // settings differ and leaves the others running.
    std::string settings;
};

enum class RealtimeMode : std::uint8_t { Off, BestEffort, Required };

struct RealtimeConfig {
    RealtimeMode mode = RealtimeMode::BestEffort;
    int priority = 50;        // SCHED_FIFO priority of the bus threads, 1-99
    std::vector<int> cpus;    // CPU affinity of the bus threads; empty: any
    bool lock_memory = true;  // lock what the threads use, once set up (rt/memory.hpp)
    // The bus thread's timer wakes it this long before each request is due and it spins on
    // the clock for the rest: a timer's wake-up is late by tens of microseconds. 0: off.
    Duration send_spin{};

    bool operator==(const RealtimeConfig&) const = default;
};

enum class RouDiMode : std::uint8_t { Auto, Embedded, External };

// The iceoryx side: where RouDi runs, and the Unix groups that decide who may watch (subscribe)
// and who may send requests, enforced by RouDi's shared-memory segments.
struct IpcConfig {
    RouDiMode roudi = RouDiMode::Auto;
    std::string watch_group = "drivebus";            // read the daemon's publications
    std::string control_group = "drivebus-control";  // send requests
    std::string daemon_group = "drivebusd";          // drivebusd alone: writes the publications
    std::size_t max_clients = 32;                    // sizes the shared memory

    bool operator==(const IpcConfig&) const = default;
};

struct Config {
    std::filesystem::path source;
    // The fragments read after it (fragment_directory()), in the order read.
    std::vector<std::filesystem::path> fragments;
    IpcConfig ipc;
    std::vector<BusConfig> buses;
    RealtimeConfig realtime;
};

// One line naming the file, the place and the problem:
// "drivebusd.toml: bus 'line1' drive 'pump': address 40 is outside 1-31 for an Altivar 58".
struct ConfigError {
    std::string message;
};

// Where profiles come from: by type along profile_search_path(), unless a directory is given.
struct LoadOptions {
    std::optional<std::filesystem::path> profile_dir;
    // The state_dir of a bus that does not set its own (state_dir_from_environment()).
    std::optional<std::filesystem::path> state_dir = std::nullopt;
};

// $DRIVEBUS_STATE_DIR, when set and not empty: the default state_dir, so that tests and
// trials keep their lease records out of /run/drivebus. An error when it is not absolute.
[[nodiscard]] std::expected<std::optional<std::filesystem::path>, ConfigError> state_dir_from_environment();

// One file of a configuration: its name, for errors, and its text.
struct ConfigText {
    std::string source;
    std::string text;
};

// The main file first, then its fragments: each fragment holds [[bus]] tables only, which
// come after the main file's buses in the order given; [realtime] and [ipc] are the main
// file's. An error names the file it is in.
[[nodiscard]] std::expected<Config, ConfigError> parse_config(std::span<const ConfigText> files,
                                                              const LoadOptions& options = {});
[[nodiscard]] std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source,
                                                              const LoadOptions& options = {});
// Where `file`'s fragments are: beside it, its name without .toml and with .d
// (/etc/drivebus/drivebusd.toml: /etc/drivebus/drivebusd.d/).
[[nodiscard]] std::filesystem::path fragment_directory(const std::filesystem::path& file);
// `file`, then every *.toml of fragment_directory(file) (if it exists) in file name order.
[[nodiscard]] std::expected<Config, ConfigError> load_config(const std::filesystem::path& file,
                                                             const LoadOptions& options = {});

// What a valid configuration still leaves unsafe, one line each, for the start-up log: a drive
// whose control lease can only fall back to "hold" keeps running when its application dies.
[[nodiscard]] std::vector<std::string> start_up_warnings(const Config& config);

// "kernel", "gpio", ...
[[nodiscard]] std::string_view to_string(DirectionMode mode) noexcept;
[[nodiscard]] std::string_view to_string(EchoMode mode) noexcept;
[[nodiscard]] std::string_view to_string(LeaseFallback fallback) noexcept;
[[nodiscard]] std::string_view to_string(RouDiMode mode) noexcept;

}  // namespace drivebus::config
