// SPDX-License-Identifier: Apache-2.0
#include "master/scheduler.hpp"

#include <algorithm>

#include "master/block_setup.hpp"

namespace drivebus::master {
namespace {

// The register a keep-alive or probe reads: the first polled one, or the first readable
// register of the profile.
std::optional<std::uint16_t> keep_alive_register(const DrivePlan& drive) {
    for (const auto& group : drive.polls) {
        if (!group.registers.empty()) {
            return group.registers.front().address;
        }
    }
    for (const auto& reg : drive.profile->registers) {
        if (reg.address && readable(reg.access)) {
            return reg.address;
        }
    }
    return std::nullopt;
}

}  // namespace

Scheduler::Scheduler(const BusPlan& bus, rtu::Instant start) : bus_(bus) {
    expired_.reserve(bus.queue_limit);
    for (const auto& d : bus.drives) {
        Drive drive;
        drive.config = &d;
        drive.limits = limits_of(*d.profile);
        drive.last_contact = start;
        for (const auto& g : d.polls) {
            drive.groups.push_back(Group{&g, plan_reads(g, *d.profile, drive.limits), start, std::nullopt});
        }
        // The selectors of the indirect blocks, as the configuration fixed them (admission
        // checks client requests through the blocks against the same values).
        drive.setup = SetupPlan(d.address, *d.profile, block_setups(d));
        drive.setup_done = drive.setup.empty();
        drive.blocks_confirmed = drive.setup.empty();
        drive.comm = CommTimeoutCheck(d.address, *d.profile, comm_timeout_raw(d), longest_request_gap(bus, d));
        if (const auto& control = d.profile->control; !drive.setup.empty() && control) {
            const RegisterInfo* status = d.profile->find(std::string_view(control->status));
            const auto bit = control->status_bits.find("fault");
            if (status != nullptr && status->address && bit != control->status_bits.end()) {
                drive.fault_flag = Drive::FaultFlag{*status->address, bit->second};
            }
        }
        drives_.push_back(std::move(drive));
    }
}

std::optional<std::size_t> Scheduler::drive_at(rtu::SlaveAddress address) const noexcept {
    for (std::size_t i = 0; i < drives_.size(); ++i) {
        if (drives_[i].config->address == address) {
            return i;
        }
    }
    return std::nullopt;
}

std::optional<Job> Scheduler::next(rtu::Instant now, bool reads_only) {
    if (!line_up_) {
        return std::nullopt;
    }
    if (fallbacks_only_) {
        return next_fallback();
    }
    if (reads_only) {
        if (auto job = next_client_read()) {
            return job;
        }
    } else {
        if (auto job = next_fallback()) {
            return job;
        }
        if (auto job = next_setup(now)) {
            return job;
        }
        if (auto job = next_check()) {
            return job;
        }
        if (auto job = take_client({&writes_})) {
            return job;
        }
        // A due poll goes between two client reads: a flood of reads cannot starve the polls
        // (and leave every snapshot stale).
        if (last_was_read_) {
            if (auto job = next_poll(now)) {
                last_was_read_ = false;
                return job;
            }
        }
        if (auto job = next_client_read()) {
            last_was_read_ = true;
            return job;
        }
    }
    if (auto job = next_poll(now)) {
        return job;
    }
    if (auto job = next_keep_alive(now)) {
        return job;
    }
    if (auto job = next_probe(now)) {
        return job;
    }
    // Writes are waiting and no read is due: read something now so that the echo decides.
    if (const auto due = next_due(); reads_only && due && *due <= now) {
        for (std::size_t d = 0; d < drives_.size(); ++d) {
            if (drives_[d].health == Health::Absent) {
                continue;
            }
            if (const auto reg = keep_alive_register(*drives_[d].config)) {
                Job job;
                job.kind = JobKind::KeepAlive;
                job.drive = d;
                job.request = {drives_[d].config->address, rtu::ReadHoldingRegisters{*reg, 1}};
                return job;
            }
        }
    }
    return std::nullopt;
}

Job Scheduler::read_job(JobKind kind, std::size_t drive, std::size_t group, std::size_t chunk) const {
    const ReadChunk& c = drives_[drive].groups[group].chunks[chunk];
    Job job;
    job.kind = kind;
    job.drive = drive;
    job.group = group;
    job.chunk = chunk;
    job.request = {drives_[drive].config->address, rtu::ReadHoldingRegisters{c.start, c.quantity}};
    return job;
}

std::optional<Job> Scheduler::next_poll(rtu::Instant now) {
    // A cycle in progress goes on; otherwise the group that has been due longest starts.
    std::optional<std::pair<std::size_t, std::size_t>> pick;
    rtu::Instant earliest = rtu::Instant::max();
    for (std::size_t d = 0; d < drives_.size(); ++d) {
        const Drive& drive = drives_[d];
        if (drive.health == Health::Absent || !drive.setup_done) {
            continue;
        }
        for (std::size_t g = 0; g < drive.groups.size(); ++g) {
            const Group& group = drive.groups[g];
            if (group.chunks.empty()) {
                continue;
            }
            if (group.cursor) {
                return read_job(JobKind::Poll, d, g, *group.cursor);
            }
            if (group.next_due <= now && group.next_due < earliest) {
                earliest = group.next_due;
                pick = {d, g};
            }
        }
    }
    if (!pick) {
        return std::nullopt;
    }
    Group& group = drives_[pick->first].groups[pick->second];
    group.cursor = 0;
    Job job = read_job(JobKind::Poll, pick->first, pick->second, 0);
    job.scheduled = group.next_due;
    // Next cycle one period on; after a late cycle, one period from now: missed cycles are not
    // caught up in a burst.
    group.next_due += group.config->period;
    if (group.next_due <= now) {
        group.next_due = now + group.config->period;
    }
    return job;
}

std::optional<Job> Scheduler::next_keep_alive(rtu::Instant now) {
    for (std::size_t d = 0; d < drives_.size(); ++d) {
        const Drive& drive = drives_[d];
        if (!drive.config->keep_alive || drive.health == Health::Absent) {
            continue;
        }
        if (now - drive.last_contact >= *drive.config->keep_alive) {
            if (const auto reg = keep_alive_register(*drive.config)) {
                Job job;
                job.kind = JobKind::KeepAlive;
                job.drive = d;
                job.request = {drive.config->address, rtu::ReadHoldingRegisters{*reg, 1}};
                return job;
            }
        }
    }
    return std::nullopt;
}

std::optional<Job> Scheduler::next_probe(rtu::Instant now) {
    for (std::size_t d = 0; d < drives_.size(); ++d) {
        const Drive& drive = drives_[d];
        if (drive.health != Health::Absent || drive.next_probe > now) {
            continue;
        }
        if (const auto reg = keep_alive_register(*drive.config)) {
            Job job;
            job.kind = JobKind::Probe;
            job.drive = d;
            job.request = {drive.config->address, rtu::ReadHoldingRegisters{*reg, 1}};
            job.retries = 0;  // one try per probe: an absent drive must not slow the others
            return job;
        }
    }
    return std::nullopt;
}

std::optional<rtu::Instant> Scheduler::next_due() const {
    if (!line_up_) {
        return std::nullopt;
    }
    std::optional<rtu::Instant> due;
    auto consider = [&](rtu::Instant t) {
        if (!due || t < *due) {
            due = t;
        }
    };
    if (queued_ > 0 || std::ranges::any_of(drives_, [](const Drive& d) { return d.fallback.has_value(); })) {
        return rtu::Instant::min();
    }
    for (const Drive& drive : drives_) {
        if (drive.comm.running() && drive.health != Health::Absent && drive.health != Health::Unknown) {
            return rtu::Instant::min();
        }
        if (!drive.setup_done && drive.health != Health::Absent) {
            consider(drive.setup_retry);  // at once, or when a failed set-up is tried again
            continue;
        }
        if (drive.health == Health::Absent) {
            consider(drive.next_probe);
            continue;
        }
        for (const Group& group : drive.groups) {
            if (group.cursor) {
                return rtu::Instant::min();
            }
            if (!group.chunks.empty()) {
                consider(group.next_due);
            }
        }
        if (drive.config->keep_alive) {
            consider(drive.last_contact + *drive.config->keep_alive);
        }
    }
    return due;
}

void Scheduler::store(std::size_t drive, const ReadChunk& chunk, const Result& result) {
    Drive& d = drives_[drive];
    const auto* words = result.response ? std::get_if<rtu::ReadHoldingRegistersResponse>(&*result.response) : nullptr;
    for (std::size_t i = 0; i < chunk.addresses.size(); ++i) {
        RegisterValue& v = d.values[chunk.addresses[i]];
        if (words != nullptr && i < words->values.size()) {
            v = {words->values[i], true, result.finished};
        } else {
            v.valid = false;
        }
    }
}

std::optional<std::size_t> Scheduler::complete(const Job& job, const Result& result, rtu::Instant now) {
    if (job.drive == kNoDrive) {
        return std::nullopt;
    }
    Drive& drive = drives_[job.drive];
    const bool answered = result.outcome == Outcome::Ok || result.outcome == Outcome::Exception;
    const Health entry = drive.health;
    if (answered) {
        mark_present(job.drive, now);
    } else if (result.outcome == Outcome::Timeout && (job.kind != JobKind::Client || job.fallback)) {
        // Silent through every retry: absent until a probe gets an answer. drivebusd's own
        // fallback write counts as much as a poll: retried ahead of the polls, it may be the
        // only request the drive gets while it is silent.
        const bool was_absent = drive.health == Health::Absent;
        mark_absent(job.drive, now);
        return was_absent ? std::nullopt : std::optional<std::size_t>(job.drive);
    }

    // Back from absence to a set-up that did not hold before: published now (an Online drive is
    // published with its next poll cycle).
    std::optional<std::size_t> back;
    if (entry == Health::Absent && drive.health != Health::Absent && drive.health != Health::Online) {
        ++drive.sequence;
        back = job.drive;
    }
    if (job.kind == JobKind::Setup) {
        const auto changed = setup_step(job, result, now);
        return changed ? changed : back;
    }
    if (job.kind == JobKind::Check) {
        const auto finished = check_step(job, result);
        return finished ? finished : back;
    }
    if (job.kind != JobKind::Poll || job.group >= drive.groups.size()) {
        return back;
    }
    Group& group = drive.groups[job.group];
    store(job.drive, group.chunks[job.chunk], result);
    watch_fault(job.drive, group.chunks[job.chunk], result);
    if (!group.cursor) {
        return std::nullopt;
    }
    *group.cursor += 1;
    if (*group.cursor < group.chunks.size()) {
        return std::nullopt;
    }
    group.cursor.reset();
    ++drive.sequence;
    return job.drive;
}

void Scheduler::mark_present(std::size_t drive, rtu::Instant now) {
    Drive& d = drives_[drive];
    d.last_contact = now;
    if (d.health == Health::Unconfigured || d.health == Health::AwaitingReset) {
        return;  // online once its set-up holds
    }
    if (d.health != Health::Online) {
        const bool was_absent = d.health == Health::Absent;
        // A drive whose set-up did not hold before it went silent is still in that state until
        // its set-up holds.
        d.health = was_absent && d.before_absence ? *d.before_absence : Health::Online;
        d.backoff = {};
        if (was_absent) {
            // It may have been switched off and on: set its blocks up and confirm them again
            // at once, and poll everything now.
            d.setup.reset_seen();
            d.setup.restart();
            d.setup_done = d.setup.empty();
            d.blocks_confirmed = d.setup.empty();
            d.setup_retry = now;
            d.setup_backoff = {};
            d.comm.restart();  // maybe another drive, or one reset to its factory settings
            for (Group& g : d.groups) {
                g.next_due = now;
                g.cursor.reset();
            }
        }
    }
}

void Scheduler::mark_absent(std::size_t drive, rtu::Instant now) {
    Drive& d = drives_[drive];
    if (d.health != Health::Absent) {
        ++d.counters.absent_transitions;
        d.before_absence = d.health == Health::Unconfigured || d.health == Health::AwaitingReset
                               ? std::optional<Health>(d.health)
                               : std::nullopt;
        d.backoff = bus_.absent_backoff_min;
    } else {
        d.backoff = std::min(d.backoff * 2, bus_.absent_backoff_max);
    }
    d.health = Health::Absent;
    d.next_probe = now + d.backoff;
    for (Group& g : d.groups) {
        g.cursor.reset();
    }
    for (auto& [address, value] : d.values) {
        value.valid = false;
    }
    ++d.sequence;
}

void Scheduler::line_down(rtu::Instant /*now*/) {
    line_up_ = false;
    for (Drive& d : drives_) {
        for (Group& g : d.groups) {
            g.cursor.reset();
        }
    }
}

void Scheduler::line_up(rtu::Instant now) {
    line_up_ = true;
    for (Drive& d : drives_) {
        d.last_contact = now;
        for (Group& g : d.groups) {
            g.next_due = now;
        }
    }
}

void Scheduler::snapshot(std::size_t drive, DriveSnapshot& s) const noexcept {
    const Drive& d = drives_[drive];
    s.bus = bus_.name;
    s.name = d.config->name;
    s.address = d.config->address;
    s.profile = d.config->profile->type;
    // On a line that is down nothing answers: what the drive was is not what it is.
    s.health = line_up_ ? d.health : Health::Unknown;
    s.registers = d.values;
    s.counters = d.counters;
    s.sequence = d.sequence;
    s.setup = d.health == Health::Unconfigured || d.health == Health::AwaitingReset ? d.setup.note() : SetupNote{};
    s.comm_timeout = d.comm.note();
}

}  // namespace drivebus::master
