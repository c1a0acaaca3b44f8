// One bus's face in shared memory: a snapshot publisher per drive, a status publisher, and the
// request server. Requests are taken off iceoryx's queue at once by an intake thread (an
// iceoryx 2.0 server may hold only four requests), checked, and handed to the bus loop's own
// bounded queue; each result is answered from the bus thread. So any number of clients, each
// with many requests outstanding, get answered, or get "queue full" without delay.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "config/config.hpp"
#include "ipc/host.hpp"
#include "master/bus_engine.hpp"

namespace drivebus::bus {
class BusLoop;
}

namespace drivebus::ipc {

// The pid of a drivebusd that already offers this bus's status, if one does.
[[nodiscard]] std::optional<int> bus_served_elsewhere(const std::string& bus);

class BusService {
public:
    BusService(const config::BusConfig& bus, const Layout& layout);
    ~BusService();
    BusService(const BusService&) = delete;
    BusService& operator=(const BusService&) = delete;
    BusService(BusService&&) = delete;
    BusService& operator=(BusService&&) = delete;

    // Called on the bus thread: publish a drive's poll cycle, answer a finished request.
    void on_snapshot(const master::DriveSnapshot& snapshot);
    void on_result(std::uint64_t correlation, const master::Result& result);

    // Starts taking requests for `loop` (which must outlive stop()). `on_thread` runs first on
    // the new thread, which also expires the control leases: it sets its scheduling.
    void start(bus::BusLoop& loop, const std::function<void()>& on_thread = {});
    void stop();

    [[nodiscard]] std::size_t drives_online() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace drivebus::ipc
