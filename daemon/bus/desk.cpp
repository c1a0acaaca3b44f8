// SPDX-License-Identifier: Apache-2.0
#include "bus/desk.hpp"

#include <string>

#include "log/log.hpp"

namespace drivebus::bus {

Desk::Desk(const config::BusConfig& bus, Handover& handover)
    : bus_(bus), handover_(handover), fallbacks_(bus.drives.size()) {}

namespace {

Refusal refusal(master::SubmitError error) noexcept {
    switch (error) {
    case master::SubmitError::QueueFull: return Refusal::QueueFull;
    case master::SubmitError::UnknownDrive: return Refusal::UnknownDrive;
    case master::SubmitError::BlockUnconfirmed: return Refusal::BlockUnconfirmed;
    }
    return Refusal::UnknownDrive;
}

}  // namespace

// Every request taken off the ring is either the engine's now or answered now: the ipc side
// frees its entry only when an answer comes back.
void Desk::take_requests() {
    master::ClientRequest request;
    while (handover_.requests.try_pop(request)) {
        if (request.withdraw) {
            handover_.put(refused(request.correlation,
                                  engine_->withdraw(request.correlation) ? Refusal::Withdrawn : Refusal::NotWithdrawn));
            continue;
        }
        if (request.fallback) {
            take_fallback(request);
            continue;
        }
        if (!engine_->up() || engine_->winding_down()) {
            handover_.put(refused(request.correlation, Refusal::BusDown));
            continue;
        }
        if (auto taken = engine_->submit(request); !taken) {
            handover_.put(refused(request.correlation, refusal(taken.error())));
        }
    }
}

// The engine's results and snapshots go to the hand-over rings, and to the caller's
// callbacks if it gave any.
master::EngineCallbacks Desk::callbacks(const master::EngineCallbacks& user) {
    master::EngineCallbacks c;
    c.snapshot = [this, user = user.snapshot](const master::DriveSnapshot& s) {
        handover_.put(s);
        if (user) {
            user(s);
        }
    };
    c.client_result = [this, user = user.client_result](std::uint64_t id, const master::Result& r) {
        if (!fallback_finished(id, r)) {
            return;  // retried
        }
        handover_.put(finished(id, r));
        if (user) {
            user(id, r);
        }
    };
    return c;
}

// A fallback write waits in its drive's own slot, ahead of every client queue, whatever
// the line's state; it is never refused for room (one per drive).
void Desk::take_fallback(const master::ClientRequest& request) {
    const auto drive = engine_->scheduler().drive_at(request.request.address);
    if (!drive) {
        handover_.put(refused(request.correlation, Refusal::UnknownDrive));
        return;
    }
    auto& f = fallbacks_[*drive];
    if (f.request || !engine_->submit(request)) {
        handover_.put(refused(request.correlation, Refusal::QueueFull));  // one already waits
        return;
    }
    f = Fallback{request, false, {}};
}

// False when `id` is a fallback that is tried again: the drive did not acknowledge it and
// is not absent. An exception is the drive's answer: no use repeating it.
bool Desk::fallback_finished(std::uint64_t id, const master::Result& r) {
    for (std::size_t d = 0; d < fallbacks_.size(); ++d) {
        auto& f = fallbacks_[d];
        if (!f.request || f.request->correlation != id) {
            continue;
        }
        if (r.outcome == master::Outcome::Ok || r.outcome == master::Outcome::Exception) {
            f.request.reset();
            return true;
        }
        log::error("bus " + bus_.name + " drive " + bus_.drives[d].name +
                       ": the fallback write was not acknowledged (" + std::string(master::to_string(r.outcome)) +
                       "); retrying",
                   {.bus = bus_.name, .drive = bus_.drives[d].name});
        f.retry = true;
        f.retry_at = r.finished + bus_.response_timeout;  // meanwhile the polls find out whether it is absent
        return false;
    }
    return true;
}

void Desk::retry_fallbacks(rtu::Instant now) {
    for (std::size_t d = 0; d < fallbacks_.size(); ++d) {
        auto& f = fallbacks_[d];
        if (!f.retry || now < f.retry_at) {
            continue;
        }
        f.retry = false;
        if (engine_->scheduler().health(d) == master::Health::Absent) {
            log::error(
                "bus " + bus_.name + " drive " + bus_.drives[d].name + ": absent; its fallback write is given up",
                {.bus = bus_.name, .drive = bus_.drives[d].name});
            master::Result gone;
            gone.finished = now;
            handover_.put(finished(f.request->correlation, gone));
            f.request.reset();
            continue;
        }
        (void)engine_->submit(*f.request);  // its slot is free: it was just taken out of it
    }
}

std::optional<rtu::Instant> Desk::next_retry() const {
    std::optional<rtu::Instant> next;
    for (const auto& f : fallbacks_) {
        if (f.retry && (!next || f.retry_at < *next)) {
            next = f.retry_at;
        }
    }
    return next;
}

}  // namespace drivebus::bus
