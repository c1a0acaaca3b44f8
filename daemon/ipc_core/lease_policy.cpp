// SPDX-License-Identifier: Apache-2.0
#include "ipc/lease_policy.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace drivebus::ipc {

LeasePolicy::LeasePolicy(const config::BusConfig& bus, TokenSource tokens)
    : bus_(bus), table_(bus, std::move(tokens)), pending_(bus.drives.size(), false), retry_(bus.drives.size()) {}

std::string LeasePolicy::name(std::size_t drive) const {
    return bus_.drives.at(drive).name;
}

std::string LeasePolicy::where(std::size_t drive) const {
    return fmt::format("bus {} drive {}", bus_.name, bus_.drives.at(drive).name);
}

std::vector<CarriedLease> LeasePolicy::carry() const {
    std::vector<CarriedLease> out;
    for (const auto& held : table_.held()) {
        out.push_back({bus_.drives.at(held.drive).name, held});
    }
    for (std::size_t d = 0; d < retry_.size(); ++d) {
        if (retry_[d] && table_.status(d).state != shm::LeaseState::Held) {
            HeldLease lease{};
            lease.drive = d;
            lease.holder.name = retry_[d]->holder;
            out.push_back({bus_.drives[d].name, lease, true});
        }
    }
    return out;
}

std::vector<Note> LeasePolicy::adopt(const std::vector<CarriedLease>& leases) {
    std::vector<Note> notes;
    for (const auto& c : leases) {
        const auto it =
            std::ranges::find_if(bus_.drives, [&](const config::DriveConfig& d) { return d.name == c.drive; });
        if (it == bus_.drives.end()) {
            notes.push_back({log::Level::Warning,
                             fmt::format("bus {}: drive {} is no longer configured: the lease {} held on it ends "
                                         "with no fallback",
                                         bus_.name, c.drive, c.lease.holder.name),
                             c.drive});
            continue;
        }
        auto lease = c.lease;
        lease.drive = static_cast<std::size_t>(it - bus_.drives.begin());
        if (c.unconfirmed) {
            retry_[lease.drive] = Retry{lease.holder.name, 1, std::nullopt};
            notes.push_back({log::Level::Warning,
                             fmt::format("{}: the fallback for the lease of {} is not confirmed yet: it is written "
                                         "again after the reload",
                                         where(lease.drive), lease.holder.name),
                             c.drive});
            continue;
        }
        table_.adopt(lease);
        notes.push_back(
            {log::Level::Info,
             fmt::format("{}: the lease of {} is kept across the reload", where(lease.drive), lease.holder.name),
             c.drive});
    }
    return notes;
}

LeaseAction LeasePolicy::command(std::size_t drive, const Origin& who, bool take_over, rtu::Instant now,
                                 std::uint64_t grant) {
    LeaseAction a;
    if (drive == kBroadcast) {
        if (const auto other = table_.other_holder(who.token)) {
            a.status = shm::Status::NotPermitted;
            a.holder = *other;
        }
        return a;
    }
    const auto d = table_.acquire(drive, who.token, Holder{who.client_name, who.pid}, take_over, now, grant);
    if (!d.allowed) {
        a.status = shm::Status::NotPermitted;
        a.holder = d.holder;
        a.note = Note{log::Level::Info,
                      fmt::format("{}: {} may not command it: {} holds the control lease", where(drive),
                                  who.client_name, d.holder.name),
                      name(drive)};
        return a;
    }
    if (grant == 0 && d.changed) {
        retry_[drive].reset();  // the new holder commands the drive now (settle() once it is sent)
    }
    if (d.taken_over) {
        a.note = Note{log::Level::Notice,
                      fmt::format("{}: {} took the control lease over", where(drive), who.client_name), name(drive)};
    }
    a.lease_ms = d.lease_ms;
    a.token = d.token;
    // A renewal only moves the expiry: subscribers hear of new holders, not of each write.
    a.republish = d.changed;
    return a;
}

LeaseAction LeasePolicy::settle(std::size_t drive, std::uint64_t grant, bool sent) {
    LeaseAction a;
    if (sent && retry_.at(drive)) {
        retry_[drive].reset();  // a holder's command reached the drive after the failed fallback
        a.note = Note{log::Level::Notice,
                      fmt::format("{}: a new holder commands it: the unconfirmed fallback is no longer written again",
                                  where(drive)),
                      name(drive)};
    }
    if (table_.settle(drive, grant, sent)) {
        a.republish = true;
        a.note =
            Note{log::Level::Info,
                 fmt::format("{}: a refused write gave back the control lease it had taken or renewed", where(drive)),
                 name(drive)};
    }
    return a;
}

LeaseAction LeasePolicy::renew(std::size_t drive, const Origin& who, rtu::Instant now) {
    const auto d = table_.renew(drive, who.token, now);
    LeaseAction a;
    a.status = d.allowed ? shm::Status::Ok : shm::Status::NotPermitted;
    a.holder = d.holder;
    a.lease_ms = d.lease_ms;
    return a;
}

LeaseAction LeasePolicy::release(std::size_t drive, const Origin& who) {
    LeaseAction a;
    if (!table_.release(drive, who.token)) {
        a.status = shm::Status::NotPermitted;
        a.note = Note{
            log::Level::Info,
            fmt::format("{}: {} may not release the control lease: it does not hold it", where(drive), who.client_name),
            name(drive)};
        return a;
    }
    a.republish = true;
    retry_[drive].reset();
    a.note = Note{log::Level::Info, fmt::format("{}: {} released the control lease", where(drive), who.client_name),
                  name(drive)};
    return a;
}

std::optional<rtu::RequestAdu> LeasePolicy::fallback_write(std::size_t drive) const {
    const auto& d = bus_.drives.at(drive);
    if (d.fallback == config::LeaseFallback::Hold || !d.profile || !d.profile->control) {
        return std::nullopt;
    }
    const auto& control = *d.profile->control;
    const auto* command = d.profile->find(control.command);
    const auto word = d.fallback == config::LeaseFallback::Stop ? control.stop : control.freewheel;
    if (command == nullptr || !command->address || !word) {
        return std::nullopt;
    }
    return rtu::RequestAdu{d.address, rtu::WriteSingleRegister{*command->address, *word}};
}

FallbackAction LeasePolicy::fallback(std::size_t drive, Note note) {
    FallbackAction f{drive, std::move(note), fallback_write(drive)};
    pending_[drive] = f.write.has_value();
    return f;
}

bool LeasePolicy::retry_waits(std::size_t drive) const {
    return retry_[drive] && !pending_[drive] && table_.status(drive).state != shm::LeaseState::Held;
}

std::vector<FallbackAction> LeasePolicy::expire(rtu::Instant now) {
    std::vector<FallbackAction> out;
    for (const auto& e : table_.expire(now)) {
        retry_[e.drive].reset();  // a fresh fallback: its own tries
        out.push_back(fallback(e.drive, Note{log::Level::Warning,
                                             fmt::format("{}: the control lease of {} ran out; fallback: {}",
                                                         where(e.drive), e.holder.name, config::to_string(e.fallback)),
                                             name(e.drive)}));
    }
    for (std::size_t d = 0; d < retry_.size(); ++d) {
        if (!retry_waits(d)) {
            continue;
        }
        if (!fallback_write(d)) {
            retry_[d].reset();  // reconfigured to hold (or no stop word): nothing left to write
            continue;
        }
        auto& r = *retry_[d];
        if (!r.next) {
            // 1 s, 2 s, 4 s ... 30 s: a drive that is off the line costs the line one time-out
            // a try, not one a poll.
            auto wait = kFirstRetry;
            for (std::uint32_t i = 1; i < r.failures && wait < kLastRetry; ++i) {
                wait *= 2;
            }
            r.next = now + std::min(wait, kLastRetry);
            continue;
        }
        if (now >= *r.next) {
            r.next.reset();
            out.push_back(
                fallback(d, Note{log::Level::Info,
                                 fmt::format("{}: writing the unconfirmed fallback again (try {}): {}", where(d),
                                             r.failures + 1, config::to_string(bus_.drives[d].fallback)),
                                 name(d)}));
        }
    }
    return out;
}

std::optional<rtu::Instant> LeasePolicy::next_deadline() const {
    auto next = table_.next_deadline();
    for (std::size_t d = 0; d < retry_.size(); ++d) {
        if (retry_waits(d) && retry_[d]->next && (!next || *retry_[d]->next < *next)) {
            next = *retry_[d]->next;
        }
    }
    return next;
}

std::vector<FallbackAction> LeasePolicy::surrender(rtu::Instant now) {
    std::vector<FallbackAction> out;
    for (const auto& e : table_.end_all(now)) {
        retry_[e.drive].reset();
        out.push_back(fallback(e.drive, Note{log::Level::Notice,
                                             fmt::format("{}: drivebusd is stopping: the control lease of {} ends; "
                                                         "fallback: {}",
                                                         where(e.drive), e.holder.name, config::to_string(e.fallback)),
                                             name(e.drive)}));
    }
    for (std::size_t d = 0; d < retry_.size(); ++d) {
        if (retry_waits(d)) {
            retry_[d]->next.reset();
            out.push_back(
                fallback(d, Note{log::Level::Notice,
                                 fmt::format("{}: drivebusd is stopping: the fallback for the lease of {} "
                                             "is not confirmed; writing it once more: {}",
                                             where(d), retry_[d]->holder, config::to_string(bus_.drives[d].fallback)),
                                 name(d)}));
        }
    }
    return out;
}

Recovery LeasePolicy::recover(const ReadLeaseRecord& record, rtu::Instant now) {
    Recovery out;
    for (const auto& problem : record.problems) {
        out.notes.push_back(
            {log::Level::Error,
             fmt::format("bus {}: lease record: {}; applying the fallback of every drive it names", bus_.name, problem),
             ""});
    }
    for (const auto& r : record.leases) {
        const auto it = std::ranges::find(bus_.drives, r.drive, &config::DriveConfig::name);
        if (it == bus_.drives.end()) {
            out.notes.push_back({log::Level::Warning,
                                 fmt::format("bus {}: the lease of {} on drive {} was held when drivebusd last "
                                             "stopped, and the drive is no longer configured: no fallback to apply",
                                             bus_.name, r.holder, r.drive),
                                 r.drive});
            continue;
        }
        const auto drive = static_cast<std::size_t>(it - bus_.drives.begin());
        if (table_.status(drive).state == shm::LeaseState::Expired) {
            continue;  // named twice
        }
        table_.recovered(drive, Holder{r.holder, 0}, now);
        std::string moved;
        if (r.address && *r.address != it->address) {
            moved = fmt::format(" (recorded at address {}, configured at {} now)", *r.address, it->address);
        }
        const auto fallback_name = config::to_string(it->fallback);
        auto text = r.unconfirmed ? fmt::format(
                                        "{}: the fallback for the lease of {} was not confirmed when drivebusd "
                                        "last stopped; applying it again: {}{}",
                                        where(drive), r.holder, fallback_name, moved)
                                  : fmt::format(
                                        "{}: the lease of {} was held when drivebusd last stopped; applying its "
                                        "fallback: {}{}",
                                        where(drive), r.holder, fallback_name, moved);
        out.fallbacks.push_back(fallback(drive, Note{log::Level::Warning, std::move(text), r.drive}));
    }
    return out;
}

std::vector<RecordedLease> LeasePolicy::record() const {
    std::vector<RecordedLease> out;
    for (std::size_t d = 0; d < bus_.drives.size(); ++d) {
        const auto s = table_.status(d);
        const auto& drive = bus_.drives[d];
        if (s.state == shm::LeaseState::Held || pending_[d]) {
            out.push_back({drive.name, drive.address, drive.fallback, std::string(shm::view(s.holder))});
        } else if (retry_[d]) {
            out.push_back({drive.name, drive.address, drive.fallback, retry_[d]->holder, true});
        }
    }
    return out;
}

bool LeasePolicy::fallbacks_pending() const {
    return std::ranges::find(pending_, true) != pending_.end();
}

LeaseAction LeasePolicy::fallback_done(std::size_t drive, master::Outcome outcome, bool refused) {
    const bool ok = !refused && outcome == master::Outcome::Ok;
    table_.fallback_result(drive, ok);
    pending_.at(drive) = false;
    LeaseAction a;
    a.republish = true;
    auto& retry = retry_.at(drive);
    if (ok) {
        if (retry) {
            a.note = Note{
                log::Level::Notice,
                fmt::format("{}: the fallback is confirmed, after {} failed write(s)", where(drive), retry->failures),
                name(drive)};
        }
        retry.reset();
        return a;
    }
    if (!retry) {
        retry = Retry{std::string(shm::view(table_.status(drive).holder)), 0, std::nullopt};
    }
    ++retry->failures;
    retry->next.reset();
    a.note =
        Note{retry->failures == 1 ? log::Level::Error : log::Level::Warning,
             fmt::format("{}: the fallback write failed: {} (failure {}); it stays in the lease record and is "
                         "written again",
                         where(drive), refused ? std::string_view("refused by the bus") : master::to_string(outcome),
                         retry->failures),
             name(drive)};
    return a;
}

}  // namespace drivebus::ipc
