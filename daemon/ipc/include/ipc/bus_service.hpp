// SPDX-License-Identifier: Apache-2.0
// One bus's face in shared memory, run by one ipc thread per bus: the intake (the request
// server), the publisher (drive snapshots, bus status) and the lease policy. The ipc thread
// owns all three alone, so none of them has a mutex; it meets the real-time bus thread only
// through the bus's hand-over rings and eventfds, so the bus thread never waits for it.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bus/bus_loop.hpp"
#include "config/config.hpp"
#include "ipc/host.hpp"
#include "ipc/intake.hpp"
#include "ipc/lease_policy.hpp"
#include "sys/wake.hpp"

namespace drivebus::ipc {

// The pid of a drivebusd that already offers this bus's status, if one does.
[[nodiscard]] std::optional<int> bus_served_elsewhere(const std::string& bus);

// What a bus restarted by a reload takes over from its former self, drive by drive (by name).
struct Carried {
    std::vector<CarriedLease> leases;
    std::vector<std::pair<std::string, std::uint64_t>> sequences;  // each drive's last snapshot's
    std::shared_ptr<Intake::Server> server;                        // with the requests waiting in it
    std::shared_ptr<sys::WakeServer> wakers;                       // with the applications connected to it
};

class BusService {
public:
    // Offers the bus's services for `loop` (which must outlive the service). `carried`: what a
    // reload carried over from the bus before its restart (BusService::retire()).
    BusService(const config::BusConfig& bus, const Layout& layout, bus::BusLoop& loop, const Carried& carried = {});
    ~BusService();
    BusService(const BusService&) = delete;
    BusService& operator=(const BusService&) = delete;
    BusService(BusService&&) = delete;
    BusService& operator=(BusService&&) = delete;

    // Starts and stops the ipc thread. `on_thread` runs first on the new thread, which also
    // expires the control leases: it sets its scheduling.
    void start(const std::function<void()>& on_thread = {});
    void stop();

    // drivebusd stops, or a reload drops the bus: no request is taken any more, and every
    // lease held ends with its drive's fallback, sent before the line is let go (stop() then
    // retire()). Returns a descriptor that turns readable once every fallback is answered
    // (acknowledged, or given up as an expiry's is): the caller polls it with its own deadline.
    // An eventfd, as between drivebusd's other threads: the ipc thread takes no lock for it.
    [[nodiscard]] int wind_down();

    // A reload restarts the bus: once this service and its loop have both stopped, answers what
    // the bus finished, then every request still waiting (refused, bus down), and returns the
    // leases held now and the snapshots' sequences for the restarted bus's service.
    [[nodiscard]] Carried retire();

    // Any thread.
    [[nodiscard]] std::size_t drives_online() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace drivebus::ipc
