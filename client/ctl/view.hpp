// SPDX-License-Identifier: Apache-2.0
// What drivebusd publishes (bus status, drive snapshots), as drivebusctl shows it: text and
// JSON. Pure: the time (CLOCK_MONOTONIC, as the payloads use) is an argument.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivebus/altivar.hpp"
#include "drivebus/shm.hpp"
#include "json.hpp"
#include "table.hpp"

namespace drivebus::ctl {

// CLOCK_MONOTONIC now, in ns (the clock of every *_ns field of the payloads).
[[nodiscard]] std::int64_t monotonic_ns() noexcept;

// One register read or held: name, address, raw, value, unit, title, bits set.
[[nodiscard]] Json register_json(std::uint16_t address, std::uint16_t raw, const RegisterInfo* info);

// Whether the profile says where the drive's state is (status word or output frequency).
[[nodiscard]] bool has_state(const Profile* profile) noexcept;
// "running forward, 30.00 Hz, no fault, no alarm".
[[nodiscard]] std::string state_text(const DriveState& state, const Profile& profile);
[[nodiscard]] Json state_json(const DriveState& state);

// "held by client 123 (expires in 800 ms, fallback stop), 0 expiries".
[[nodiscard]] std::string lease_text(const shm::LeaseStatus& lease, std::int64_t now_ns);
[[nodiscard]] Json lease_json(const shm::LeaseStatus& lease, std::int64_t now_ns);

// A drive's latest snapshot: fields, then a table of its registers.
[[nodiscard]] std::string drive_status_text(const shm::DriveSnapshot& s, const Profile* profile, std::int64_t now_ns);
[[nodiscard]] Json drive_status_json(const shm::DriveSnapshot& s, const Profile* profile, std::int64_t now_ns);

// The bus: device, state, drives, counters, timing.
[[nodiscard]] std::string bus_status_text(const shm::BusStatus& s, bool can_request, std::int64_t now_ns);
[[nodiscard]] Json bus_status_json(const shm::BusStatus& s, bool can_request, std::int64_t now_ns);
// The drives a bus status lists: NAME ADDRESS PROFILE HEALTH (header first).
[[nodiscard]] std::vector<Row> drive_rows(const shm::BusStatus& s);
[[nodiscard]] Json drives_json(const shm::BusStatus& s);

// One drive in `drivebusctl watch`.
struct WatchDrive {
    std::string name;
    std::uint8_t address = 0;
    std::string profile_type;
    shm::DriveHealth health = shm::DriveHealth::Unknown;
    std::optional<shm::DriveSnapshot> snapshot;
    const Profile* profile = nullptr;
};

// The key values of a drive: its decoded state when the profile says where it is, otherwise
// its first registers with their units ("W450=12 W451=0 W452=7").
[[nodiscard]] std::string key_values(const WatchDrive& drive);
// The watch screen as lines (no escape codes): a title, the drives' table, the bus line.
[[nodiscard]] std::vector<std::string> watch_lines(const shm::BusStatus& bus, const std::vector<WatchDrive>& drives,
                                                   std::chrono::milliseconds interval, std::int64_t now_ns);
[[nodiscard]] Json watch_json(const shm::BusStatus& bus, const std::vector<WatchDrive>& drives, std::int64_t now_ns);

}  // namespace drivebus::ctl
