// One bus, one thread, one event loop: the OS side of the master. It owns the serial port and
// the direction control, turns fd and timer readiness into BusEngine events, writes what the
// engine asks for, finds out when each request has left the wire, and reopens the port with
// back-off when the device goes away.
#pragma once

#include <atomic>
#include <expected>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "master/bus_engine.hpp"

namespace drivebus::bus {

// One request's write, as the bus thread saw it.
struct WriteTrace {
    rtu::Instant due;                       // its poll's due time or the end of the t3.5 silence, whichever is later
    rtu::Instant writing;                   // write() called
    rtu::Instant written;                   // write() returned
    unsigned attempt = 1;                   // 2 and more: a retry
    std::optional<rtu::Instant> scheduled;  // a poll cycle's first request: when its period made it due
};

struct LoopOptions {
    // Real time for the bus thread; nullopt: normal scheduling.
    std::optional<config::RealtimeConfig> realtime;
    // How long before a request's send time the timer wakes the thread, which then spins on
    // the clock to the exact instant (0: the timer's own wake-up sends it).
    rtu::Duration send_spin{};
    // Called on the bus thread after each request's write(). For benchmarks.
    std::function<void(const WriteTrace&)> on_written;
};

class BusLoop {
public:
    BusLoop(const config::BusConfig& bus, master::EngineCallbacks callbacks, LoopOptions options = {});
    ~BusLoop();
    BusLoop(const BusLoop&) = delete;
    BusLoop& operator=(const BusLoop&) = delete;
    BusLoop(BusLoop&&) = delete;
    BusLoop& operator=(BusLoop&&) = delete;

    // Starts the thread. Fails when real time is required and not granted.
    std::expected<void, std::string> start();
    void stop();

    // Thread-safe: queues a client request for the bus thread.
    std::expected<void, master::SubmitError> submit(master::ClientRequest request);
    // Thread-safe copy of the bus status.
    [[nodiscard]] master::BusStatus status() const;
    // Whether the line is open, without copying the status.
    [[nodiscard]] bool up() const noexcept { return up_.load(std::memory_order_relaxed); }
    // How often the loop has gone round: at least twice a second while it is alive, so a
    // watchdog can check it moves.
    [[nodiscard]] std::uint64_t heartbeat() const noexcept { return heartbeat_.load(); }
    [[nodiscard]] const config::BusConfig& config() const noexcept { return bus_; }

private:
    class Impl;
    const config::BusConfig& bus_;
    master::EngineCallbacks callbacks_;
    LoopOptions options_;
    std::unique_ptr<Impl> impl_;
    std::thread thread_;
    std::atomic<std::uint64_t> heartbeat_{0};
    std::atomic<bool> up_{false};
};

}  // namespace drivebus::bus
