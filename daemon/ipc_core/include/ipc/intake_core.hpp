// SPDX-License-Identifier: Apache-2.0
// The intake's decisions, without iceoryx: a request taken from shared memory is admitted (or
// rejected), checked against the leases, booked under the one queue limit and handed to the
// bus, or answered at once; a result coming back from the bus frees its entry and becomes the
// answer. Every request leaves through exactly one answer. Each request comes with a RouteId,
// chosen by the caller, that names where its answer goes (drivebusd: the iceoryx request
// header it keeps under that id); the answer hands it back. `Submit` hands a request to the
// bus and returns false when it cannot take it. Pure: what is worth a log line leaves as a
// Note.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "ipc/lease_policy.hpp"
#include "ipc/pending.hpp"
#include "master/finished.hpp"

namespace drivebus::ipc {

class IntakeCore {
public:
    using Submit = std::function<bool(const master::ClientRequest&)>;
    // Makes the lease record durable (LeasePolicy::record()): called when a command has taken a
    // lease (or taken it over), before the command goes to the bus, so that no drive is sent
    // a command its lease record does not name.
    using Journal = std::function<void()>;
    // The port a request's route answers to (Origin::port). Without one, the client's own id
    // stands for it (for callers that have no ports).
    using PortOf = std::function<std::uint64_t(RouteId)>;
    // Where its notes go (a lease taken, renewed or refused; a rejected request); none: dropped.
    using Notes = std::function<void(const Note&)>;

    IntakeCore(const config::BusConfig& bus, LeasePolicy& leases, Submit submit, Journal journal = {},
               PortOf port_of = {}, Notes notes = {});

    // A request from a client. Returns the answer to send now through `route`; nullopt: the
    // request is booked with its route and the bus will answer (finish() hands `route` back).
    std::optional<shm::Response> accept(const shm::Request& request, RouteId route, bool bus_up, rtu::Instant now);

    // drivebusd is stopping and has ended the leases: from now on every request is answered
    // bus down, so that none takes a lease again or reaches the drive after its fallback.
    void close() noexcept { closed_ = true; }

    // drivebusd's own write (a lease fallback): outside the clients' limit.
    bool submit_own(std::size_t drive, const rtu::RequestAdu& write);

    struct Answer {
        PendingBook::Entry entry;  // its routes: where the response goes
        shm::Response response;
    };
    // The bus answered: the entry leaves the book, and the response goes to its route and to
    // its withdrawal's, if any (the request finished first: the withdrawal learns its result).
    // A fallback's outcome goes to the lease policy (its entry has no route). A withdrawal that
    // came too late is answered Sent, and the entry stays for the request's own result.
    // Nullopt for an id not booked.
    std::optional<Answer> finish(const master::Finished& f, bool abandoned = false);

    // The bus has ended (a reload restarts it) and answered all it will: every request still
    // booked is answered refused, bus down.
    std::vector<Answer> abandon();

    // Drives whose lease snapshot changed since the last call.
    std::vector<std::size_t> take_republish();
    [[nodiscard]] const PendingBook& book() const noexcept { return book_; }
    [[nodiscard]] std::uint64_t served() const noexcept { return served_; }
    // Requests answered QueueFull at the limit (the bus's own refusals are counted by the bus).
    [[nodiscard]] std::uint64_t queue_full() const noexcept { return queue_full_; }

private:
    // A Withdraw: the request it names goes to the bus for withdrawal, and the answer waits for
    // the bus's word; a request not in the book, or already asked to withdraw, is answered
    // NotPending at once (so no client can fill the rings to the bus thread with withdrawals).
    std::optional<shm::Response> withdraw(const Origin& who, RouteId route);
    // A request that took or renewed a lease has been sent, or refused: the grant stands, or
    // is undone and its answer carries no lease.
    void settle(std::uint64_t id, Origin& who, bool sent);
    shm::Response answer(const Origin& who, shm::Status status, shm::RejectReason reason = shm::RejectReason::None,
                         std::uint16_t address = 0, const Holder& holder = {});
    void act(std::size_t drive, const LeaseAction& a);

    const config::BusConfig& bus_;
    LeasePolicy& leases_;
    Submit submit_;
    Journal journal_;
    PortOf port_of_;
    Notes notes_;
    PendingBook book_;
    std::vector<std::size_t> republish_;
    std::uint64_t served_ = 0;
    std::uint64_t queue_full_ = 0;
    bool closed_ = false;
};

}  // namespace drivebus::ipc
