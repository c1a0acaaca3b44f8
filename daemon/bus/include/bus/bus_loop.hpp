// SPDX-License-Identifier: Apache-2.0
// One bus, one thread, one event loop: the OS side of the master. It owns the serial port and
// the direction control, turns fd and timer readiness into BusEngine events, writes what the
// engine asks for, finds out when each request has left the wire, and reopens the port with
// back-off when the device goes away.
#pragma once

#include <atomic>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "bus/handover.hpp"
#include "config/config.hpp"
#include "log/log.hpp"
#include "master/bus_engine.hpp"
#include "sys/event_fd.hpp"
#include "sys/seqlock.hpp"

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
    // A request the port's output buffer has not taken within this is the line lost.
    rtu::Duration output_stall = std::chrono::seconds(1);
};

// What other threads see of the bus: the engine's status without the name, copied through a
// seqlock so that no reader can hold the bus thread up.
struct StatusCopy {
    bool up = false;
    master::BusCounters counters;
    master::TimingStats reply_latency;
    master::TimingStats extra_gap;
    std::uint64_t sequence = 0;
};

// Every member that other threads use is lock-free: the hand-over rings, atomics and the
// seqlocked status. The bus thread shares no mutex with anyone.
class BusLoop {
public:
    // `callbacks` are called on the bus thread as well as the hand-over (tests, benchmarks).
    BusLoop(const config::BusConfig& bus, master::EngineCallbacks callbacks, LoopOptions options = {});
    ~BusLoop();
    BusLoop(const BusLoop&) = delete;
    BusLoop& operator=(const BusLoop&) = delete;
    BusLoop(BusLoop&&) = delete;
    BusLoop& operator=(BusLoop&&) = delete;

    // Starts the thread. Fails when real time is required and not granted.
    std::expected<void, std::string> start();
    void stop();
    // drivebusd stops: the bus sends nothing but the lease fallbacks submitted before this
    // (the clients' waiting requests are answered bus down); stop() then lets the line go.
    void wind_down();

    // Queues a client request for the bus thread through the request ring; its result comes
    // back through handover().results. One thread only may submit (the ring's one producer).
    // QueueFull: the ring is full.
    std::expected<void, master::SubmitError> submit(const master::ClientRequest& request);
    // Any thread: a copy of the bus status.
    [[nodiscard]] master::BusStatus status() const;
    // The rings between the bus thread and the ipc thread.
    [[nodiscard]] Handover& handover() noexcept { return handover_; }
    // Whether the line is open, without copying the status.
    [[nodiscard]] bool up() const noexcept { return up_.load(std::memory_order_relaxed); }
    // How often the loop has gone round: at least twice a second while it is alive, so a
    // watchdog can check it moves.
    [[nodiscard]] std::uint64_t heartbeat() const noexcept { return heartbeat_.load(); }
    [[nodiscard]] const config::BusConfig& config() const noexcept { return bus_; }

    // What runs on the bus thread (bus_thread.hpp); only BusLoop makes one.
    class Impl;

private:
    const config::BusConfig& bus_;
    master::EngineCallbacks callbacks_;
    LoopOptions options_;
    Handover handover_;
    sys::Seqlock<StatusCopy> status_;
    log::Ring log_;      // the bus thread's log lines, written by the log's drain thread
    sys::EventFd wake_;  // the bus thread's: a request is waiting, or stop
    std::unique_ptr<Impl> impl_;
    std::thread thread_;
    std::atomic<std::uint64_t> heartbeat_{0};
    std::atomic<bool> up_{false};
    std::atomic<bool> winding_{false};
};

}  // namespace drivebus::bus
