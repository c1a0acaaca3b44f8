// SPDX-License-Identifier: Apache-2.0
// libdrivebus's values as Python ones: durations in seconds, statuses and decoded states as
// dicts, snapshots as drivebus.Snapshot.
#pragma once

#include <string_view>

#include "common.hpp"

namespace drivebus::python {

// Seconds (a float, as Python's time functions take) to milliseconds; InvalidArgument when
// negative or not finite.
[[nodiscard]] Milliseconds milliseconds_of(double seconds, std::string_view what);

[[nodiscard]] py::dict status_dict(const shm::BusStatus& status, bool daemon_alive);
[[nodiscard]] py::dict lease_dict(const shm::LeaseStatus& lease);
[[nodiscard]] py::dict state_dict(const DriveState& state);

// A snapshot with the drive it came from (its profile names the registers and gives their units).
struct Snapshot {
    shm::DriveSnapshot data;
    Drive drive;
};

void define_snapshot(py::module_& m);

}  // namespace drivebus::python
