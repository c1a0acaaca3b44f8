// SPDX-License-Identifier: Apache-2.0
// What runs on a bus's thread (bus_thread.cpp): its event loop, port, direction control and
// engine. BusLoop (bus_loop.cpp) is the handle other threads hold: it starts and stops the
// thread and shares with it only the rings, the wake-up eventfd and a few atomics.
#pragma once

#include <atomic>
#include <expected>
#include <memory>
#include <string>

#include "bus/bus_loop.hpp"

namespace drivebus::bus {

class BusLoop::Impl {
public:
    // What the thread shares with BusLoop.
    struct Shared {
        std::atomic<bool>& up;
        Handover& handover;
        sys::Seqlock<StatusCopy>& status;
        std::atomic<std::uint64_t>& heartbeat;
        const sys::EventFd& wake;          // a request is waiting, or stop
        const std::atomic<bool>& winding;  // BusLoop::wind_down()
    };

    // Builds the thread's loop (on the calling thread); fails when the loop cannot watch its
    // own descriptors.
    [[nodiscard]] static std::expected<std::unique_ptr<Impl>, std::string> create(
        const config::BusConfig& bus, const master::EngineCallbacks& callbacks, const LoopOptions& options,
        BusLoop& outer);
    Impl() = default;
    virtual ~Impl() = default;
    Impl(const Impl&) = delete;
    Impl& operator=(const Impl&) = delete;
    Impl(Impl&&) = delete;
    Impl& operator=(Impl&&) = delete;

    // On the bus thread: runs until request_stop().
    virtual void run() = 0;
    // From any thread.
    virtual void request_stop() noexcept = 0;
};

}  // namespace drivebus::bus
