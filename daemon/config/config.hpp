// drivebusd's configuration: parsed and validated once at start-up into this immutable
// struct. Nothing is opened before it is valid. See docs/configuration.md.
#pragma once

#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivebus/profile.hpp"
#include "rtu/timing.hpp"
#include "serial/direction.hpp"

namespace drivebus::config {

using Duration = std::chrono::nanoseconds;

enum class DirectionMode : std::uint8_t { Kernel, Gpio, Rts, None };
enum class EchoMode : std::uint8_t { Off, On, Auto };

// A register a poll group reads: resolved against the drive's profile.
struct PolledRegister {
    std::string name;         // the profile's name ("FD00"), or "0x1234" for a bare number
    std::uint16_t address = 0;
};

struct PollGroup {
    std::string name;                       // "fast", or "group1" when unnamed
    std::vector<PolledRegister> registers;  // in the order given
    Duration period{};
    // Read through the drive's indirect read block (ATV21: 0x1875, up to 5 registers chosen
    // by F875-F879, which drivebusd writes when the drive comes online): one transaction.
    bool indirect = false;
};

enum class LeaseFallback : std::uint8_t { Hold, Stop, Freewheel };

struct DriveConfig {
    std::string name;                         // unique on the bus
    std::uint8_t address = 1;
    std::shared_ptr<const Profile> profile;   // loaded by type
    std::vector<PollGroup> polls;
    // A request at least this often even when nothing polls the drive, so that it stays
    // inside its Modbus time-out (ATV21 F803). Absent: off.
    std::optional<Duration> keep_alive;
    // A client that writes the profile's command or reference holds the drive's control lease
    // and must renew it within `lease`; when it does not, drivebusd applies `fallback`.
    Duration lease = std::chrono::seconds(1);
    LeaseFallback fallback = LeaseFallback::Hold;
    // The registers the indirect write block's slots select (`write_block`, ATV21: through
    // F870/F871), in slot order; empty: drivebusd leaves the write block alone. What drivebusd
    // writes at set-up follows from this and the indirect poll: master::block_setups().
    std::vector<std::uint16_t> write_block;
};

struct BusConfig {
    std::string name;                        // unique; names the iceoryx services
    std::filesystem::path device;
    rtu::LineFormat format;                  // default 19200 8E1
    DirectionMode direction = DirectionMode::None;
    serial::KernelRs485Options kernel;       // for DirectionMode::Kernel
    std::optional<serial::GpioOptions> gpio; // required for DirectionMode::Gpio
    // Used when the kernel says it has no RS485 support: rts, none, or nullopt (fail).
    std::optional<DirectionMode> kernel_fallback;
    EchoMode echo = EchoMode::Off;
    Duration response_timeout = std::chrono::milliseconds(100);
    unsigned retries = 2;                    // after the first attempt
    Duration broadcast_turnaround = std::chrono::milliseconds(10);
    // After a time-out, how long a late reply may still come before anything is sent again;
    // unset: response_timeout.
    std::optional<Duration> late_reply_guard;
    // How long past its wire bound a reply may still be completed by bytes the kernel held back
    // (rtu::Framer::set_delivery_allowance()).
    Duration delivery_allowance = std::chrono::milliseconds(50);
    Duration absent_backoff_min = std::chrono::seconds(1);  // re-probe of an absent drive
    Duration absent_backoff_max = std::chrono::seconds(30);
    std::size_t queue_limit = 64;            // client requests waiting on this bus
    std::filesystem::path lock_dir;          // UUCP lock files; empty: none
    std::vector<DriveConfig> drives;
};

enum class RealtimeMode : std::uint8_t { Off, BestEffort, Required };

struct RealtimeConfig {
    RealtimeMode mode = RealtimeMode::BestEffort;
    int priority = 50;            // SCHED_FIFO priority of the bus threads, 1-99
    std::vector<int> cpus;        // CPU affinity of the bus threads; empty: any
    bool lock_memory = true;      // lock what the threads use, once set up (rt/memory.hpp)
    // The bus thread's timer wakes it this long before each request is due and it spins on
    // the clock for the rest: a timer's wake-up is late by tens of microseconds. 0: off.
    Duration send_spin{};
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
};

struct Config {
    std::filesystem::path source;
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
};

[[nodiscard]] std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source,
                                                              const LoadOptions& options = {});
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
