// SPDX-License-Identifier: Apache-2.0
// From what the master knows to the shared-memory payloads. Pure: the time of publication and
// drivebusd's pid come from the caller.
#pragma once

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "master/finished.hpp"
#include "master/result.hpp"
#include "master/snapshot.hpp"

namespace drivebus::ipc {

[[nodiscard]] std::int64_t monotonic_ns(rtu::Instant t) noexcept;

// What a payload says of its publication.
struct Publication {
    std::int64_t published_ns = 0;  // CLOCK_MONOTONIC, as monotonic_ns() gives it
    std::int32_t daemon_pid = 0;    // the bus status's only
};

// Fills `out` (a loaned chunk) from the master's snapshot; the lease is the caller's.
void fill_snapshot(const master::DriveSnapshot& in, const Publication& publication, shm::DriveSnapshot& out) noexcept;

void fill_status(const config::BusConfig& bus, const master::BusStatus& in, const std::vector<shm::DriveHealth>& health,
                 const Publication& publication, shm::BusStatus& out) noexcept;

// The response to a request the bus took: its outcome, or why it was refused.
void fill_response(const master::Finished& finished, shm::Response& out) noexcept;
void fill_response(const master::Result& result, shm::Response& out) noexcept;

[[nodiscard]] shm::DriveHealth to_shm(master::Health health) noexcept;
[[nodiscard]] shm::CommTimeout to_shm(const master::CommTimeoutNote& note) noexcept;

}  // namespace drivebus::ipc
