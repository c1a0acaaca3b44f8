#include "ipc/lease.hpp"

#include <chrono>

namespace drivebus::ipc {
namespace {

std::int64_t ns(rtu::Instant t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

std::uint32_t ms(rtu::Duration d) {
    return static_cast<std::uint32_t>(std::chrono::duration_cast<std::chrono::milliseconds>(d).count());
}

}  // namespace

LeaseTable::LeaseTable(const config::BusConfig& bus) {
    for (const auto& d : bus.drives) {
        Lease l;
        l.duration = std::chrono::duration_cast<rtu::Duration>(d.lease);
        l.fallback = d.fallback;
        leases_.push_back(std::move(l));
    }
}

LeaseDecision LeaseTable::acquire(std::size_t drive, std::uint64_t client, std::string_view name, bool take_over,
                                  rtu::Instant now) {
    auto& l = leases_.at(drive);
    const bool live = l.state == shm::LeaseState::Held && l.expires > now;
    if (live && l.holder != client && !take_over) {
        return {false, false, false, l.holder, l.holder_name, 0};
    }
    const bool moved = live && l.holder != client;
    const bool renewal = live && l.holder == client;
    l.holder = client;
    l.holder_name = std::string(name);
    l.state = shm::LeaseState::Held;
    l.expires = now + l.duration;
    return {true, moved, !renewal, client, l.holder_name, ms(l.duration)};
}

LeaseDecision LeaseTable::renew(std::size_t drive, std::uint64_t client, rtu::Instant now) {
    auto& l = leases_.at(drive);
    if (l.state != shm::LeaseState::Held || l.holder != client || l.expires <= now) {
        return {false, false, false, l.state == shm::LeaseState::Held ? l.holder : 0, l.holder_name, 0};
    }
    l.expires = now + l.duration;
    return {true, false, false, client, l.holder_name, ms(l.duration)};
}

bool LeaseTable::release(std::size_t drive, std::uint64_t client) {
    auto& l = leases_.at(drive);
    if (l.state != shm::LeaseState::Held || l.holder != client) {
        return false;
    }
    l.state = shm::LeaseState::Free;
    l.holder = 0;
    l.holder_name.clear();
    return true;
}

std::optional<std::uint64_t> LeaseTable::other_holder(std::uint64_t client) const {
    for (const auto& l : leases_) {
        if (l.state == shm::LeaseState::Held && l.holder != client) {
            return l.holder;
        }
    }
    return std::nullopt;
}

std::vector<Expiry> LeaseTable::expire(rtu::Instant now) {
    std::vector<Expiry> out;
    for (std::size_t i = 0; i < leases_.size(); ++i) {
        auto& l = leases_[i];
        if (l.state == shm::LeaseState::Held && l.expires <= now) {
            l.state = shm::LeaseState::Expired;
            l.expired = now;
            l.fallback_ok = false;
            ++l.expiries;
            ++expiries_;
            out.push_back({i, l.holder, l.holder_name, l.fallback});
        }
    }
    return out;
}

std::optional<rtu::Instant> LeaseTable::next_deadline() const {
    std::optional<rtu::Instant> next;
    for (const auto& l : leases_) {
        if (l.state == shm::LeaseState::Held && (!next || l.expires < *next)) {
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
    // An expired lease still names its last holder: whose application stopped renewing.
    s.holder = l.state == shm::LeaseState::Free ? 0 : l.holder;
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
