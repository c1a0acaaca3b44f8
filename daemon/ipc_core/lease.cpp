// SPDX-License-Identifier: Apache-2.0
#include "ipc/lease.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace drivebus::ipc {
namespace {

std::int64_t ns(rtu::Instant t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

std::uint32_t ms(rtu::Duration d) {
    return static_cast<std::uint32_t>(std::chrono::duration_cast<std::chrono::milliseconds>(d).count());
}

bool zero(const LeaseToken& t) {
    return (t[0] | t[1]) == 0;
}

// Compares every word whatever the first differs in: how long a refusal takes says nothing of
// how much of a guess was right.
bool same(const LeaseToken& a, const LeaseToken& b) {
    return ((a[0] ^ b[0]) | (a[1] ^ b[1])) == 0;
}

}  // namespace

LeaseTable::LeaseTable(const config::BusConfig& bus, TokenSource tokens) : tokens_(std::move(tokens)) {
    if (!tokens_) {
        throw std::invalid_argument("bus " + bus.name + ": control leases need a token source");
    }
    for (const auto& d : bus.drives) {
        Lease l;
        l.duration = std::chrono::duration_cast<rtu::Duration>(d.lease);
        l.fallback = d.fallback;
        leases_.push_back(std::move(l));
    }
}

std::vector<HeldLease> LeaseTable::held() const {
    std::vector<HeldLease> out;
    for (std::size_t i = 0; i < leases_.size(); ++i) {
        if (const auto& l = leases_[i]; l.state == shm::LeaseState::Held) {
            out.push_back({i, l.holder, l.token, l.expires});
        }
    }
    return out;
}

void LeaseTable::adopt(const HeldLease& lease) {
    auto& l = leases_.at(lease.drive);
    l.holder = lease.holder;
    l.token = lease.token;
    l.expires = lease.expires;
    l.state = shm::LeaseState::Held;
    l.fallback_ok = false;
    changed(l);
}

bool LeaseTable::held_under(const Lease& l, const LeaseToken& token) {
    return l.state == shm::LeaseState::Held && !zero(token) && same(l.token, token);
}

LeaseToken LeaseTable::token_for(const LeaseToken& presented) {
    // A token only its holder knows, still held (this lease run out but not yet expired, or
    // another drive's): the same client, so the same token, and its other leases stay valid.
    for (const auto& l : leases_) {
        if (held_under(l, presented)) {
            return presented;
        }
    }
    for (;;) {
        const auto fresh = tokens_();
        if (!zero(fresh)) {
            return fresh;
        }
    }
}

LeaseDecision LeaseTable::acquire(std::size_t drive, const LeaseToken& token, const Holder& who, bool take_over,
                                  rtu::Instant now, std::uint64_t grant) {
    auto& l = leases_.at(drive);
    const bool live = l.state == shm::LeaseState::Held && l.expires > now;
    const bool renewal = live && held_under(l, token);
    if (live && !renewal && !take_over) {
        return {false, false, false, l.holder, {}, 0};
    }
    const Taken before = l;
    l.expires = now + l.duration;
    changed(l);
    if (grant != 0) {
        l.unsettled.push_back({grant, before, l.epoch});
    }
    if (renewal) {
        return {true, false, false, l.holder, {}, ms(l.duration)};
    }
    // Taken, or taken over: the token moves, so the former holder's next request is refused.
    l.token = token_for(token);
    l.holder = who;
    l.state = shm::LeaseState::Held;
    return {true, live, true, l.holder, l.token, ms(l.duration)};
}

LeaseDecision LeaseTable::renew(std::size_t drive, const LeaseToken& token, rtu::Instant now) {
    auto& l = leases_.at(drive);
    if (!held_under(l, token) || l.expires <= now) {
        return {false, false, false, l.state == shm::LeaseState::Held ? l.holder : Holder{}, {}, 0};
    }
    l.expires = now + l.duration;
    changed(l);
    return {true, false, false, l.holder, {}, ms(l.duration)};
}

bool LeaseTable::settle(std::size_t drive, std::uint64_t grant, bool sent) {
    auto& l = leases_.at(drive);
    const auto it = std::ranges::find(l.unsettled, grant, &Grant::id);
    if (it == l.unsettled.end()) {
        return false;
    }
    const Grant g = *it;
    l.unsettled.erase(it);
    if (sent) {
        return false;
    }
    if (l.epoch == g.epoch_after) {
        static_cast<Taken&>(l) = g.before;  // nothing changed it since: exactly as it was
        return true;
    }
    // The next grant was made on top of this one: undoing that one now undoes both.
    const auto next = std::ranges::find(l.unsettled, g.epoch_after, [](const Grant& n) { return n.before.epoch; });
    if (next != l.unsettled.end()) {
        next->before = g.before;
    }
    // Otherwise a settled change (a take-over, a release) came after it, and stands.
    return false;
}

bool LeaseTable::release(std::size_t drive, const LeaseToken& token) {
    auto& l = leases_.at(drive);
    if (!held_under(l, token)) {
        return false;
    }
    l.state = shm::LeaseState::Free;
    l.token = {};
    l.holder = {};
    changed(l);
    return true;
}

std::optional<Holder> LeaseTable::other_holder(const LeaseToken& token) const {
    for (const auto& l : leases_) {
        if (l.state == shm::LeaseState::Held && !held_under(l, token)) {
            return l.holder;
        }
    }
    return std::nullopt;
}

void LeaseTable::end(std::size_t drive, rtu::Instant now) {
    auto& l = leases_[drive];
    l.state = shm::LeaseState::Expired;
    l.token = {};  // nothing renews or releases it any more
    changed(l);    // a grant still unsettled cannot undo the end
    l.expired = now;
    l.fallback_ok = false;
    ++l.expiries;
    ++expiries_;
}

std::vector<Expiry> LeaseTable::expire(rtu::Instant now) {
    std::vector<Expiry> out;
    for (std::size_t i = 0; i < leases_.size(); ++i) {
        if (const auto& l = leases_[i]; l.state == shm::LeaseState::Held && l.expires <= now && l.unsettled.empty()) {
            end(i, now);
            out.push_back({i, l.holder, l.fallback});
        }
    }
    return out;
}

std::vector<Expiry> LeaseTable::end_all(rtu::Instant now) {
    std::vector<Expiry> out;
    for (std::size_t i = 0; i < leases_.size(); ++i) {
        if (const auto& l = leases_[i]; l.state == shm::LeaseState::Held) {
            end(i, now);
            out.push_back({i, l.holder, l.fallback});
        }
    }
    return out;
}

void LeaseTable::recovered(std::size_t drive, const Holder& who, rtu::Instant now) {
    leases_.at(drive).holder = who;
    end(drive, now);
}

std::optional<rtu::Instant> LeaseTable::next_deadline() const {
    std::optional<rtu::Instant> next;
    for (const auto& l : leases_) {
        // One with a grant unsettled waits for the bus's word, which comes with a result.
        if (l.state == shm::LeaseState::Held && l.unsettled.empty() && (!next || l.expires < *next)) {
            next = l.expires;
        }
    }
    return next;
}

void LeaseTable::fallback_result(std::size_t drive, bool ok) {
    leases_.at(drive).fallback_ok = ok;
}

shm::LeaseStatus LeaseTable::status(std::size_t drive) const {
    const auto& l = leases_.at(drive);
    shm::LeaseStatus s;
    // An expired lease still names its last holder: whose application stopped renewing. Only
    // the name and pid: the token is the holder's alone.
    if (l.state != shm::LeaseState::Free) {
        shm::assign(s.holder, l.holder.name);
        s.holder_pid = l.holder.pid;
    }
    s.expires_ns = l.state == shm::LeaseState::Held ? ns(l.expires) : 0;
    s.duration_ms = ms(l.duration);
    s.state = l.state;
    s.fallback = static_cast<shm::Fallback>(l.fallback);
    s.fallback_ok = l.fallback_ok ? 1 : 0;
    s.expired_ns = l.expiries > 0 ? ns(l.expired) : 0;
    s.expiries = l.expiries;
    return s;
}

}  // namespace drivebus::ipc
