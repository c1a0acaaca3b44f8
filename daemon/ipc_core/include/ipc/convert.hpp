// SPDX-License-Identifier: Apache-2.0
// From what the master knows to the shared-memory payloads. Pure.
#pragma once

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "master/finished.hpp"
#include "master/result.hpp"
#include "master/snapshot.hpp"

namespace drivebus::ipc {

[[nodiscard]] std::int64_t monotonic_ns(rtu::Instant t) noexcept;

// Fills `out` (a loaned chunk) from the master's snapshot; the lease is the caller's.
void fill_snapshot(const master::DriveSnapshot& in, shm::DriveSnapshot& out) noexcept;

void fill_status(const config::BusConfig& bus, const master::BusStatus& in, const std::vector<shm::DriveHealth>& health,
                 shm::BusStatus& out) noexcept;

// The response to a request the bus took: its outcome, or why it was refused.
void fill_response(const master::Finished& finished, shm::Response& out) noexcept;
void fill_response(const master::Result& result, shm::Response& out) noexcept;

[[nodiscard]] shm::DriveHealth to_shm(master::Health health) noexcept;
[[nodiscard]] shm::CommTimeout to_shm(const master::CommTimeoutNote& note) noexcept;

}  // namespace drivebus::ipc
