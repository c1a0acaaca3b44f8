// SPDX-License-Identifier: Apache-2.0
// What the master runs on one bus: its drives, what it polls of each, its time-outs and retries.
// The master's own description, plain values; the configuration fills it (BusPlan
// is a BusPlan and the line's settings), tests and benchmarks build it directly.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivebus/profile.hpp"
#include "rtu/timing.hpp"

namespace drivebus::master {

using Duration = std::chrono::nanoseconds;

enum class EchoMode : std::uint8_t { Off, On, Auto };

// A register a poll group reads: resolved against the drive's profile.
struct PolledRegister {
    std::string name;  // the profile's name ("FD00"), or "0x1234" for a bare number
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

struct DrivePlan {
    std::string name;  // unique on the bus
    std::uint8_t address = 1;
    std::shared_ptr<const Profile> profile;  // loaded by type
    std::vector<PollGroup> polls;
    // A request at least this often even when nothing polls the drive, so that it stays
    // inside its Modbus time-out (ATV21 F803). Absent: off.
    std::optional<Duration> keep_alive;
    // The registers the indirect write block's slots select (`write_block`, ATV21: through
    // F870/F871), in slot order; empty: drivebusd leaves the write block alone. What drivebusd
    // writes at set-up follows from this and the indirect poll: block_setups().
    std::vector<std::uint16_t> write_block;
    // Not the master's: the control lease the ipc side keeps for this drive. A client that
    // writes the profile's command or reference holds it and must renew it within `lease`;
    // when it does not, drivebusd applies `fallback` (through the master, as a write).
    Duration lease = std::chrono::seconds(1);
    LeaseFallback fallback = LeaseFallback::Hold;
    // The drive's own Modbus time-out (its profile's [safety] comm_timeout, ATV21: F803) that
    // drivebusd writes when the drive comes online, only if it holds another value; read back.
    // Absent: read and judged, never written (master/comm_timeout.hpp).
    std::optional<Duration> comm_timeout;
};

struct BusPlan {
    std::string name;        // unique; names the iceoryx services
    rtu::LineFormat format;  // default 19200 8E1: the character times
    EchoMode echo = EchoMode::Off;
    Duration response_timeout = std::chrono::milliseconds(100);
    unsigned retries = 2;  // after the first attempt
    Duration broadcast_turnaround = std::chrono::milliseconds(10);
    // After a time-out, how long a late reply may still come before anything is sent again;
    // unset: response_timeout.
    std::optional<Duration> late_reply_guard;
    // How long past its wire bound a reply may still be completed by bytes the kernel held back
    // (rtu::Framer::set_delivery_allowance()).
    Duration delivery_allowance = std::chrono::milliseconds(50);
    Duration absent_backoff_min = std::chrono::seconds(1);  // re-probe of an absent drive
    Duration absent_backoff_max = std::chrono::seconds(30);
    std::size_t queue_limit = 64;  // client requests waiting on this bus
    std::vector<DrivePlan> drives;
};

}  // namespace drivebus::master
