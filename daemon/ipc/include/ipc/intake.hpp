// SPDX-License-Identifier: Apache-2.0
// A bus's request server in shared memory: requests are taken off iceoryx's queue as soon as
// they arrive (an iceoryx 2.0 server holds only four at a time), decided by the IntakeCore
// (admission, leases, the one queue limit) and handed to the bus through its ring, or answered
// at once; the bus's results come back through the hand-over and are answered here. Runs on
// the ipc thread only; iceoryx's listener thread merely wakes it through an eventfd.
#pragma once

#include <functional>
#include <memory>

#include "bus/bus_loop.hpp"
#include "config/config.hpp"
#include "ipc/lease_policy.hpp"
#include "sys/posix.hpp"

namespace drivebus::ipc {

class Intake {
public:
    // The bus's iceoryx server, with the requests waiting in it: a reload that restarts the bus
    // hands it to the restarted bus's intake, so that clients never see it go away.
    struct Server;

    // `adopted`: the server of the bus before its restart (release()); a new one otherwise.
    // `journal`: makes the lease record durable before a command that took a lease is sent
    // (IntakeCore::Journal).
    Intake(const config::BusConfig& bus, bus::BusLoop& loop, LeasePolicy& leases,
           std::shared_ptr<Server> adopted = nullptr, std::function<void()> journal = {});
    ~Intake();
    Intake(const Intake&) = delete;
    Intake& operator=(const Intake&) = delete;
    Intake(Intake&&) = delete;
    Intake& operator=(Intake&&) = delete;

    // Readable when requests may be waiting; then call take().
    [[nodiscard]] int ready_fd() const noexcept;
    // Takes every waiting request and answers or submits each.
    void take(rtu::Instant now);
    // Answers what the bus finished.
    void answer(const master::Finished& f);
    // After the bus thread has ended: answers every request still waiting, refused, bus down.
    void abandon();
    // Stops listening and gives the server up for the restarted bus's intake.
    [[nodiscard]] std::shared_ptr<Server> release();
    // drivebusd stops: every request from now on is answered bus down (IntakeCore::close()).
    void close() noexcept;
    // A lease fallback's write; false when the bus could not take it.
    bool submit_own(std::size_t drive, const rtu::RequestAdu& write);
    // Drives whose lease snapshot changed since the last call.
    [[nodiscard]] std::vector<std::size_t> take_republish();

    [[nodiscard]] std::uint64_t served() const noexcept;
    // Responses sent so far, of every kind.
    [[nodiscard]] std::uint64_t answers() const noexcept;
    [[nodiscard]] std::uint64_t queue_full() const noexcept;
    [[nodiscard]] std::size_t in_flight() const noexcept;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace drivebus::ipc
