// SPDX-License-Identifier: Apache-2.0
// The intake's decisions, without iceoryx: a request taken from shared memory is admitted (or
// rejected), checked against the leases, booked under the one queue limit and handed to the
// bus, or answered at once; a result coming back from the bus frees its entry and becomes the
// answer. Every request leaves through exactly one answer. `Route` is what the caller needs
// to send that answer (an iceoryx request header); `Submit` hands a request to the bus and
// returns false when it cannot take it. Pure: what is worth a log line leaves as a Note.
#pragma once

#include <fmt/format.h>

#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "ipc/admission.hpp"
#include "ipc/convert.hpp"
#include "ipc/lease_policy.hpp"
#include "ipc/pending.hpp"
#include "master/finished.hpp"

namespace drivebus::ipc {

template <typename Route>
class IntakeCore {
public:
    using Submit = std::function<bool(const master::ClientRequest&)>;
    // Makes the lease record durable (LeasePolicy::record()): called when a command has taken a
    // lease (or taken it over), before the command goes to the bus, so that no drive is sent
    // a command its lease record does not name.
    using Journal = std::function<void()>;
    // The port a request's route answers to (Origin::port). Without one, the client's own id
    // stands for it (for callers that have no ports).
    using PortOf = std::function<std::uint64_t(const Route&)>;
    // Where its notes go (a lease taken, renewed or refused; a rejected request); none: dropped.
    using Notes = std::function<void(const Note&)>;

    IntakeCore(const config::BusConfig& bus, LeasePolicy& leases, Submit submit, Journal journal = {},
               PortOf port_of = {}, Notes notes = {})
        : bus_(bus),
          leases_(leases),
          submit_(std::move(submit)),
          journal_(std::move(journal)),
          port_of_(std::move(port_of)),
          notes_(std::move(notes)),
          book_(bus.queue_limit) {}

    // A request from a client. Returns the answer to send now with `route`; nullopt: the
    // request and its route are booked and the bus will answer.
    std::optional<shm::Response> accept(const shm::Request& request, Route& route, bool bus_up, rtu::Instant now) {
        Origin who{request.correlation, request.client, std::string(shm::view(request.client_name)), request.kind};
        who.token = request.lease_token;
        who.pid = request.pid;
        who.port = port_of_ ? port_of_(route) : request.client;
        if (closed_) {
            return answer(who, shm::Status::BusDown);
        }
        if (request.kind == shm::RequestKind::Withdraw && shm::compatible(request)) {
            return withdraw(who, route);
        }
        auto admitted = admit(bus_, request);
        if (!admitted) {
            if (notes_) {
                notes_(Note{log::Level::Info,
                            fmt::format("bus {}: request from {} rejected: {}", bus_.name, who.client_name,
                                        admitted.error().why),
                            {}});
            }
            return answer(who, shm::Status::Rejected, admitted.error().reason, admitted.error().register_address);
        }
        who.drive = admitted->drive;
        if (!admitted->on_wire) {
            const auto a = request.kind == shm::RequestKind::LeaseRelease ? leases_.release(who.drive, who)
                                                                          : leases_.renew(who.drive, who, now);
            act(who.drive, a);
            who.lease_ms = a.lease_ms;
            return answer(who, a.status, shm::RejectReason::None, 0, a.holder);
        }
        // Every refusal that can be told now comes before the lease: a refused request changes
        // nothing. What the bus refuses later undoes the lease's grant (finish()).
        if (request.deadline_ns != 0 && request.deadline_ns <= monotonic_ns(now)) {
            return answer(who, shm::Status::Expired);
        }
        if (!bus_up) {
            return answer(who, shm::Status::BusDown);
        }
        // A write under a drive's lease may use the room kept for control (refused the lease,
        // it leaves the book at once: no flood of refused writes holds that room).
        const bool control = admitted->touches_control && who.drive != kBroadcast;
        const auto id = book_.book(who, std::move(route), control ? Room::Control : Room::Shared);
        if (!id) {
            return answer(who, shm::Status::QueueFull);
        }
        if (admitted->touches_control) {
            const auto a = leases_.command(who.drive, who, (request.flags & shm::kFlagTakeOver) != 0, now, *id);
            act(who.drive, a);
            auto& booked = book_.entry(*id)->origin;
            if (a.status != shm::Status::Ok) {
                route = std::move(*book_.finish(*id)->route);
                return answer(who, a.status, shm::RejectReason::None, request.start, a.holder);
            }
            booked.lease_ms = a.lease_ms;
            booked.granted = a.token;  // whatever the bus then answers, the taker learns its token
            booked.grant = who.drive != kBroadcast;
            if (a.republish && journal_) {
                journal_();  // written ahead: the record names the holder before its command is sent
            }
        }
        if (!submit_(master::ClientRequest{request.client, *id, admitted->request,
                                           request.kind == shm::RequestKind::Probe, false, false,
                                           deadline_of(request)})) {
            // Cannot happen while the bus's ring is sized to the limit; answered all the same.
            auto entry = book_.finish(*id);
            route = std::move(*entry->route);
            settle(*id, entry->origin, false);
            return answer(entry->origin, shm::Status::QueueFull);
        }
        return std::nullopt;
    }

    // drivebusd is stopping and has ended the leases: from now on every request is answered
    // bus down, so that none takes a lease again or reaches the drive after its fallback.
    void close() noexcept { closed_ = true; }

    // drivebusd's own write (a lease fallback): outside the clients' limit.
    bool submit_own(std::size_t drive, const rtu::RequestAdu& write) {
        Origin own{0, 0, "drivebusd fallback", shm::RequestKind::Write, drive};
        const auto id = book_.book_own(own);
        if (submit_(master::ClientRequest{0, id, write, false, true})) {
            return true;
        }
        (void)book_.finish(id);
        return false;
    }

    struct Answer {
        typename PendingBook<Route>::Entry entry;  // its routes: where the response goes
        shm::Response response;
    };
    // The bus answered: the entry leaves the book, and the response goes to its route and to
    // its withdrawal's, if any (the request finished first: the withdrawal learns its result).
    // A fallback's outcome goes to the lease policy (its entry has no route). A withdrawal that
    // came too late is answered Sent, and the entry stays for the request's own result.
    // Nullopt for an id not booked.
    std::optional<Answer> finish(const master::Finished& f, bool abandoned = false) {
        if (f.refusal == master::Refusal::NotWithdrawn) {
            auto* e = book_.entry(f.id);
            if (e == nullptr || !e->withdrawal) {
                return std::nullopt;  // it finished meanwhile: its result answered the withdrawal
            }
            Answer a{{e->origin, std::nullopt, std::exchange(e->withdrawal, std::nullopt)}, response_shell(e->origin)};
            a.response.status = shm::Status::Sent;
            return a;
        }
        auto entry = book_.finish(f.id);
        if (!entry) {
            return std::nullopt;
        }
        // Refused by the bus: never sent. Abandoned: perhaps sent (the lease stays, to be safe).
        settle(f.id, entry->origin, f.refusal == master::Refusal::None || abandoned);
        ++served_;
        if (entry->origin.fallback) {
            act(entry->origin.drive,
                leases_.fallback_done(entry->origin.drive, f.outcome, f.refusal != master::Refusal::None));
        }
        Answer a{std::move(*entry), response_shell(entry->origin)};
        fill_response(f, a.response);
        return a;
    }

    // The bus has ended (a reload restarts it) and answered all it will: every request still
    // booked is answered refused, bus down.
    std::vector<Answer> abandon() {
        std::vector<Answer> out;
        for (const auto id : book_.ids()) {
            master::Finished f;
            f.id = id;
            f.refusal = master::Refusal::BusDown;
            f.outcome = master::Outcome::BusDown;
            if (auto a = finish(f, true)) {
                out.push_back(std::move(*a));
            }
        }
        return out;
    }

    // Drives whose lease snapshot changed since the last call.
    std::vector<std::size_t> take_republish() { return std::exchange(republish_, {}); }
    [[nodiscard]] const PendingBook<Route>& book() const noexcept { return book_; }
    [[nodiscard]] std::uint64_t served() const noexcept { return served_; }
    // Requests answered QueueFull at the limit (the bus's own refusals are counted by the bus).
    [[nodiscard]] std::uint64_t queue_full() const noexcept { return queue_full_; }

private:
    // A Withdraw: the request it names goes to the bus for withdrawal, and the answer waits for
    // the bus's word; a request not in the book, or already asked to withdraw, is answered
    // NotPending at once (so no client can fill the rings to the bus thread with withdrawals).
    std::optional<shm::Response> withdraw(const Origin& who, Route& route) {
        const auto id = book_.find(who.port, who.client, who.correlation);
        auto* e = id ? book_.entry(*id) : nullptr;
        if (e == nullptr || e->withdrawal_asked) {
            return answer(who, shm::Status::Rejected, shm::RejectReason::NotPending);
        }
        e->withdrawal_asked = true;
        master::ClientRequest order;
        order.client = who.client;
        order.correlation = *id;
        order.withdraw = true;
        if (!submit_(order)) {
            return answer(who, shm::Status::Sent);  // cannot tell: said as the worse case
        }
        e->withdrawal = std::move(route);
        return std::nullopt;
    }

    // A request that took or renewed a lease has been sent, or refused: the grant stands, or
    // is undone and its answer carries no lease.
    void settle(std::uint64_t id, Origin& who, bool sent) {
        if (!who.grant) {
            return;
        }
        act(who.drive, leases_.settle(who.drive, id, sent));
        if (!sent) {
            who.lease_ms = 0;
            who.granted = {};
        }
    }

    static std::optional<rtu::Instant> deadline_of(const shm::Request& r) {
        if (r.deadline_ns == 0) {
            return std::nullopt;
        }
        return rtu::Instant{
            std::chrono::duration_cast<rtu::Instant::duration>(std::chrono::nanoseconds(r.deadline_ns))};
    }

    static shm::Response response_shell(const Origin& who) {
        shm::Response r{};
        r.size = sizeof r;
        r.correlation = who.correlation;
        r.lease_ms = who.lease_ms;
        r.lease_token = who.granted;
        return r;
    }

    shm::Response answer(const Origin& who, shm::Status status, shm::RejectReason reason = shm::RejectReason::None,
                         std::uint16_t address = 0, const Holder& holder = {}) {
        ++served_;
        queue_full_ += status == shm::Status::QueueFull ? 1 : 0;
        auto r = response_shell(who);
        r.status = status;
        r.reason = reason;
        r.register_address = address;
        shm::assign(r.lease_holder, holder.name);  // who holds it, never its token
        r.lease_holder_pid = holder.pid;
        return r;
    }

    void act(std::size_t drive, const LeaseAction& a) {
        if (a.note && notes_) {
            notes_(*a.note);
        }
        if (a.republish && drive != kBroadcast) {
            republish_.push_back(drive);
        }
    }

    const config::BusConfig& bus_;
    LeasePolicy& leases_;
    Submit submit_;
    Journal journal_;
    PortOf port_of_;
    Notes notes_;
    PendingBook<Route> book_;
    std::vector<std::size_t> republish_;
    std::uint64_t served_ = 0;
    std::uint64_t queue_full_ = 0;
    bool closed_ = false;
};

}  // namespace drivebus::ipc
