// SPDX-License-Identifier: Apache-2.0
// What the real-time bus thread and the ipc thread hand each other, and how: lock-free
// single-producer single-consumer rings with preallocated slots, plus an eventfd that wakes
// the ipc side. Nothing here blocks the bus thread, allocates on it, or takes a lock.
//
//   ipc -> bus   requests    client requests, bounded by the intake's queue limit, and at most
//                            one withdrawal of each
//   bus -> ipc   results     one entry per request taken: its outcome, or why it was refused,
//                            and one per withdrawal that came too late (NotWithdrawn).
//                            Sized to twice the queue limit plus one fallback per drive, and every
//                            entry belongs to a request the ipc side still has in flight, so
//                            it cannot overflow; if it ever did, the push is counted in
//                            `results_lost` (a defect, logged by the ipc side).
//   bus -> ipc   snapshots   each drive's poll cycle. A full ring drops the snapshot (counted
//                            in `snapshots_dropped`): the next cycle brings a newer one.
#pragma once

#include <atomic>
#include <cstdint>

#include "master/finished.hpp"
#include "master/scheduler.hpp"
#include "master/snapshot.hpp"
#include "sys/event_fd.hpp"
#include "sys/posix.hpp"
#include "sys/spsc_ring.hpp"

namespace drivebus::bus {

// The outcome the bus thread hands back: the master's result in fixed form.
using master::Finished;
using master::finished;
using master::Refusal;
using master::refused;

class Handover {
public:
    Handover(std::size_t queue_limit, std::size_t drives);

    sys::SpscRing<master::ClientRequest> requests;
    sys::SpscRing<Finished> results;
    sys::SpscRing<master::DriveSnapshot> snapshots;
    std::atomic<std::uint64_t> snapshots_dropped{0};
    std::atomic<std::uint64_t> results_lost{0};

    // Bus thread: hand over a result or a snapshot; flush() then wakes the ipc side, once for
    // all that was put, when the bus thread has done its work and is about to wait (waking
    // another thread in the middle of it could hand that thread the CPU first).
    void put(const Finished& f) noexcept;
    void put(const master::DriveSnapshot& s) noexcept;
    void flush() noexcept;

    // The ipc side waits for this fd to be readable, then calls acknowledge() and drains.
    [[nodiscard]] int ready_fd() const noexcept { return ready_.fd(); }
    void acknowledge() const noexcept;

private:
    sys::EventFd ready_;
    bool unflushed_ = false;  // the bus thread's own
};

}  // namespace drivebus::bus
