#include "master/scheduler.hpp"

#include <algorithm>

namespace drivebus::master {
namespace {

constexpr rtu::FunctionCode kRead = rtu::FunctionCode::ReadHoldingRegisters;

// The register a keep-alive or probe reads: the first polled one, or the first readable
// register of the profile.
std::optional<std::uint16_t> keep_alive_register(const config::DriveConfig& drive) {
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

rtu::FunctionLimits limits_of(const Profile& profile) {
    rtu::FunctionLimits limits;
    limits.max_address = profile.address_max;
    limits.max_read = profile.functions.read_holding_max;
    limits.max_write = profile.functions.write_multiple_max;
    limits.write_single = profile.functions.write_single;
    limits.device_identification = profile.functions.device_identification;
    const auto& broadcast = profile.functions.broadcast;
    limits.broadcast_write_single = std::ranges::find(broadcast, std::uint8_t{6}) != broadcast.end();
    limits.broadcast_write_multiple = std::ranges::find(broadcast, std::uint8_t{16}) != broadcast.end();
    for (const auto& block : profile.indirect_blocks) {
        limits.windows.push_back({block.function == 3 ? kRead : rtu::FunctionCode::WriteMultipleRegisters,
                                  block.address, block.min_quantity, block.max_quantity});
    }
    return limits;
}

std::vector<ReadChunk> plan_reads(const config::PollGroup& group, const Profile& profile,
                                  const rtu::FunctionLimits& limits) {
    std::vector<ReadChunk> chunks;
    if (group.indirect) {
        if (const IndirectBlock* block = profile.block(3)) {
            ReadChunk chunk{block->address, static_cast<std::uint16_t>(group.registers.size()), {}};
            for (const auto& r : group.registers) {
                chunk.addresses.push_back(r.address);
            }
            chunks.push_back(std::move(chunk));
        }
        return chunks;
    }
    // Consecutive registers share a transaction up to the drive's plain read limit.
    const std::uint16_t max = std::max<std::uint16_t>(1, limits.max_read);
    for (const auto& r : group.registers) {
        if (!chunks.empty()) {
            ReadChunk& last = chunks.back();
            if (r.address == static_cast<std::uint16_t>(last.start + last.quantity) && last.quantity < max &&
                last.start + last.quantity <= 0xFFFF) {
                ++last.quantity;
                last.addresses.push_back(r.address);
                continue;
            }
        }
        chunks.push_back(ReadChunk{r.address, 1, {r.address}});
    }
    return chunks;
}

Scheduler::Scheduler(const config::BusConfig& bus, rtu::Instant start) : bus_(bus) {
    for (const auto& d : bus.drives) {
        Drive drive;
        drive.config = &d;
        drive.limits = limits_of(*d.profile);
        drive.last_contact = start;
        for (const auto& g : d.polls) {
            drive.groups.push_back(Group{&g, plan_reads(g, *d.profile, drive.limits), start, std::nullopt});
            if (g.indirect && drive.setup.empty()) {
                // Point the block's selectors at the polled registers; the rest select nothing.
                const IndirectBlock* block = d.profile->block(3);
                for (std::size_t slot = 0; block != nullptr && slot < block->selectors.size(); ++slot) {
                    std::uint16_t choice = 0;
                    if (slot < g.registers.size()) {
                        for (const auto& [code, name] : block->choices) {
                            const RegisterInfo* target = d.profile->find(std::string_view(name));
                            if (target != nullptr && target->address == g.registers[slot].address) {
                                choice = code;
                            }
                        }
                    }
                    const RegisterInfo* selector = d.profile->find(std::string_view(block->selectors[slot]));
                    if (selector != nullptr && selector->address) {
                        drive.setup.emplace_back(*selector->address, choice);
                    }
                }
                drive.setup_done = drive.setup.empty();
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

std::expected<void, SubmitError> Scheduler::submit(ClientRequest request) {
    Job job;
    job.kind = JobKind::Client;
    job.client = request.client;
    job.correlation = request.correlation;
    job.request = request.request;
    if (request.request.address == rtu::kBroadcastAddress) {
        job.drive = kNoDrive;
    } else if (request.probe) {
        job.drive = kNoDrive;  // no drive's counters or health: it may not be configured
        job.retries = 0;
    } else if (const auto d = drive_at(request.request.address)) {
        job.drive = *d;
    } else {
        return std::unexpected(SubmitError::UnknownDrive);
    }
    if (request.fallback) {
        if (job.drive == kNoDrive) {
            return std::unexpected(SubmitError::UnknownDrive);
        }
        if (drives_[job.drive].fallback) {
            return std::unexpected(SubmitError::QueueFull);
        }
        drives_[job.drive].fallback = std::move(job);
        return {};
    }
    if (queued_ >= bus_.queue_limit) {
        return std::unexpected(SubmitError::QueueFull);
    }
    const bool write = !std::holds_alternative<rtu::ReadHoldingRegisters>(request.request.pdu) &&
                       !std::holds_alternative<rtu::ReadDeviceIdentification>(request.request.pdu);
    (write ? writes_ : reads_)[request.client].push_back(std::move(job));
    ++queued_;
    return {};
}

std::optional<Job> Scheduler::next(rtu::Instant now, bool reads_only) {
    if (!line_up_) {
        return std::nullopt;
    }
    if (reads_only) {
        if (auto job = next_client_read()) {
            return job;
        }
    } else {
        if (auto job = next_fallback()) {
            return job;
        }
        if (auto job = next_setup()) {
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

std::optional<Job> Scheduler::next_client_read() {
    return take_client({&reads_});
}

std::optional<Job> Scheduler::take_client(std::initializer_list<std::map<std::uint64_t, std::deque<Job>>*> order) {
    for (auto* queues : order) {
        if (queues->empty()) {
            continue;
        }
        // Round-robin: the first client after the one served last.
        auto it = queues->upper_bound(last_client_);
        if (it == queues->end()) {
            it = queues->begin();
        }
        Job job = std::move(it->second.front());
        it->second.pop_front();
        last_client_ = it->first;
        if (it->second.empty()) {
            queues->erase(it);
        }
        --queued_;
        return job;
    }
    return std::nullopt;
}

std::optional<Job> Scheduler::next_fallback() {
    for (Drive& drive : drives_) {
        if (drive.fallback) {
            return std::exchange(drive.fallback, std::nullopt);
        }
    }
    return std::nullopt;
}

std::optional<Job> Scheduler::next_setup() {
    for (std::size_t d = 0; d < drives_.size(); ++d) {
        Drive& drive = drives_[d];
        if (drive.setup_done || drive.health == Health::Absent || drive.setup_cursor >= drive.setup.size()) {
            continue;
        }
        const auto [address, value] = drive.setup[drive.setup_cursor];
        Job job;
        job.kind = JobKind::Setup;
        job.drive = d;
        job.chunk = drive.setup_cursor;
        job.request = {drive.config->address, rtu::WriteSingleRegister{address, value}};
        ++drive.setup_cursor;
        return job;
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
        if (!drive.setup_done && drive.health != Health::Absent) {
            return rtu::Instant::min();
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
    if (answered) {
        mark_present(job.drive, now);
    } else if (result.outcome == Outcome::Timeout && job.kind != JobKind::Client) {
        // Silent through every retry: absent until a probe gets an answer.
        const bool was_absent = drive.health == Health::Absent;
        mark_absent(job.drive, now);
        return was_absent ? std::nullopt : std::optional<std::size_t>(job.drive);
    }

    if (job.kind == JobKind::Setup && drive.setup_cursor >= drive.setup.size()) {
        drive.setup_done = true;
    }
    if (job.kind != JobKind::Poll || job.group >= drive.groups.size()) {
        return std::nullopt;
    }
    Group& group = drive.groups[job.group];
    store(job.drive, group.chunks[job.chunk], result);
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
    if (d.health != Health::Online) {
        const bool was_absent = d.health == Health::Absent;
        d.health = Health::Online;
        d.backoff = {};
        if (was_absent) {
            // It may have restarted: set its blocks up again and poll everything now.
            d.setup_cursor = 0;
            d.setup_done = d.setup.empty();
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

std::vector<Job> Scheduler::take_client_jobs() {
    std::vector<Job> jobs;
    for (auto* queues : {&writes_, &reads_}) {
        for (auto& [client, queue] : *queues) {
            jobs.insert(jobs.end(), queue.begin(), queue.end());
        }
        queues->clear();
    }
    queued_ = 0;
    return jobs;
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
    s.health = d.health;
    s.registers = d.values;
    s.counters = d.counters;
    s.sequence = d.sequence;
}

}  // namespace drivebus::master
