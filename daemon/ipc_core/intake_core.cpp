// SPDX-License-Identifier: Apache-2.0
#include "ipc/intake_core.hpp"

#include <fmt/format.h>

#include <chrono>
#include <string>
#include <utility>

#include "ipc/admission.hpp"
#include "ipc/convert.hpp"

namespace drivebus::ipc {

namespace {

std::optional<rtu::Instant> deadline_of(const shm::Request& r) {
    if (r.deadline_ns == 0) {
        return std::nullopt;
    }
    return rtu::Instant{std::chrono::duration_cast<rtu::Instant::duration>(std::chrono::nanoseconds(r.deadline_ns))};
}

shm::Response response_shell(const Origin& who) {
    shm::Response r{};
    r.size = sizeof r;
    r.correlation = who.correlation;
    r.lease_ms = who.lease_ms;
    r.lease_token = who.granted;
    return r;
}

}  // namespace

IntakeCore::IntakeCore(const config::BusConfig& bus, LeasePolicy& leases, Submit submit, Journal journal,
                       PortOf port_of, Notes notes)
    : bus_(bus),
      leases_(leases),
      submit_(std::move(submit)),
      journal_(std::move(journal)),
      port_of_(std::move(port_of)),
      notes_(std::move(notes)),
      book_(bus.queue_limit) {}

std::optional<shm::Response> IntakeCore::accept(const shm::Request& request, RouteId route, bool bus_up,
                                                rtu::Instant now) {
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
            notes_(Note{
                log::Level::Info,
                fmt::format("bus {}: request from {} rejected: {}", bus_.name, who.client_name, admitted.error().why),
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
    const auto id = book_.book(who, route, control ? Room::Control : Room::Shared);
    if (!id) {
        return answer(who, shm::Status::QueueFull);
    }
    if (admitted->touches_control) {
        const auto a = leases_.command(who.drive, who, (request.flags & shm::kFlagTakeOver) != 0, now, *id);
        act(who.drive, a);
        auto& booked = book_.entry(*id)->origin;
        if (a.status != shm::Status::Ok) {
            (void)book_.finish(*id);  // answered now, through `route`
            return answer(who, a.status, shm::RejectReason::None, request.start, a.holder);
        }
        booked.lease_ms = a.lease_ms;
        booked.granted = a.token;  // whatever the bus then answers, the taker learns its token
        booked.grant = who.drive != kBroadcast;
        if (a.republish && journal_) {
            journal_();  // written ahead: the record names the holder before its command is sent
        }
    }
    if (!submit_(master::ClientRequest{request.client, *id, admitted->request, request.kind == shm::RequestKind::Probe,
                                       false, false, deadline_of(request)})) {
        // Cannot happen while the bus's ring is sized to the limit; answered all the same.
        auto entry = book_.finish(*id);
        settle(*id, entry->origin, false);
        return answer(entry->origin, shm::Status::QueueFull);
    }
    return std::nullopt;
}

bool IntakeCore::submit_own(std::size_t drive, const rtu::RequestAdu& write) {
    Origin own{0, 0, "drivebusd fallback", shm::RequestKind::Write, drive};
    const auto id = book_.book_own(own);
    if (submit_(master::ClientRequest{0, id, write, false, true})) {
        return true;
    }
    (void)book_.finish(id);
    return false;
}

std::optional<IntakeCore::Answer> IntakeCore::finish(const master::Finished& f, bool abandoned) {
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

std::vector<IntakeCore::Answer> IntakeCore::abandon() {
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

std::vector<std::size_t> IntakeCore::take_republish() {
    return std::exchange(republish_, {});
}

std::optional<shm::Response> IntakeCore::withdraw(const Origin& who, RouteId route) {
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
    e->withdrawal = route;
    return std::nullopt;
}

void IntakeCore::settle(std::uint64_t id, Origin& who, bool sent) {
    if (!who.grant) {
        return;
    }
    act(who.drive, leases_.settle(who.drive, id, sent));
    if (!sent) {
        who.lease_ms = 0;
        who.granted = {};
    }
}

shm::Response IntakeCore::answer(const Origin& who, shm::Status status, shm::RejectReason reason, std::uint16_t address,
                                 const Holder& holder) {
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

void IntakeCore::act(std::size_t drive, const LeaseAction& a) {
    if (a.note && notes_) {
        notes_(*a.note);
    }
    if (a.republish && drive != kBroadcast) {
        republish_.push_back(drive);
    }
}

}  // namespace drivebus::ipc
