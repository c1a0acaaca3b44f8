// SPDX-License-Identifier: Apache-2.0
#include "bus/handover.hpp"

#include <unistd.h>

#include <algorithm>
#include <stdexcept>

namespace drivebus::bus {
namespace {

// Snapshots wait in the ring only until the ipc thread wakes; a few cycles of every drive
// cover a slow wake-up.
constexpr std::size_t kSnapshotsPerDrive = 4;
constexpr std::size_t kMinSnapshots = 16;

}  // namespace

Handover::Handover(std::size_t queue_limit, std::size_t drives)
    // Each client request may be followed by its withdrawal, and each withdrawal answered apart
    // from the request's own result: twice the limit, and a fallback per drive.
    : requests(2 * queue_limit + drives),
      results(2 * queue_limit + drives),
      snapshots(std::max(kMinSnapshots, kSnapshotsPerDrive * drives)),
      ready_("eventfd for the bus thread's hand-over") {}

void Handover::put(const Finished& f) noexcept {
    if (!results.try_push(f)) {
        results_lost.fetch_add(1, std::memory_order_relaxed);
    }
    unflushed_ = true;
}

void Handover::put(const master::DriveSnapshot& s) noexcept {
    if (!snapshots.try_push(s)) {
        snapshots_dropped.fetch_add(1, std::memory_order_relaxed);
    }
    unflushed_ = true;
}

void Handover::flush() noexcept {
    if (!unflushed_) {
        return;
    }
    unflushed_ = false;
    ready_.signal();
}

void Handover::acknowledge() const noexcept {
    ready_.drain();
}

}  // namespace drivebus::bus
