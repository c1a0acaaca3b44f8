// SPDX-License-Identifier: Apache-2.0
#include "ipc/publisher.hpp"

#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <chrono>
#include <cstring>

#include "iceoryx_posh/popo/publisher.hpp"
#include "ipc/convert.hpp"
#include "ipc/service.hpp"
#include "master/comm_timeout.hpp"
#include "sys/posix.hpp"

namespace drivebus::ipc {
namespace {

iox::popo::PublisherOptions history_one() {
    iox::popo::PublisherOptions options;
    options.historyCapacity = 1;
    return options;
}

}  // namespace

struct Publisher::Channels {
    explicit Channels(const config::BusConfig& bus) : status(service(bus.name, shm::kStatusEvent), history_one()) {
        for (const auto& d : bus.drives) {
            drives.push_back(std::make_unique<iox::popo::Publisher<shm::DriveSnapshot>>(
                service(bus.name, std::string(shm::kDriveEventPrefix) + d.name), history_one()));
        }
    }
    iox::popo::Publisher<shm::BusStatus> status;
    std::vector<std::unique_ptr<iox::popo::Publisher<shm::DriveSnapshot>>> drives;
};

Publisher::Publisher(const config::BusConfig& bus, const Layout& layout)
    : bus_(bus),
      control_group_(layout.control_group),
      channels_(std::make_unique<Channels>(bus)),
      last_(bus.drives.size()),
      health_(bus.drives.size(), master::Health::Unknown),
      comm_timeout_logged_(bus.drives.size(), false) {
    // Before its first poll cycle a drive's snapshot is a shell: names, no values.
    for (std::size_t i = 0; i < bus.drives.size(); ++i) {
        const auto& d = bus.drives[i];
        auto& s = last_[i];
        s.size = sizeof(shm::DriveSnapshot);
        shm::assign(s.bus, bus.name);
        shm::assign(s.name, d.name);
        shm::assign(s.profile, d.profile ? d.profile->type : "");
        s.address = d.address;
    }
}

Publisher::~Publisher() = default;

std::optional<std::size_t> Publisher::drive_index(std::string_view name) const {
    const auto it = std::ranges::find_if(bus_.drives, [&](const auto& d) { return d.name == name; });
    if (it == bus_.drives.end()) {
        return std::nullopt;
    }
    return static_cast<std::size_t>(it - bus_.drives.begin());
}

bool Publisher::snapshot(std::size_t drive, const master::DriveSnapshot& s, const shm::LeaseStatus& lease) {
    const std::uint64_t sequence = last_[drive].sequence;
    fill_snapshot(s, {.published_ns = monotonic_ns(std::chrono::steady_clock::now()), .daemon_pid = 0}, last_[drive]);
    last_[drive].sequence = sequence;
    last_[drive].lease = lease;
    publish(drive);
    log_comm_timeout(drive, s.comm_timeout);
    const auto before = health_[drive];
    if (before == s.health) {
        return false;
    }
    health_[drive] = s.health;
    online_.store(static_cast<std::size_t>(std::ranges::count(health_, master::Health::Online)),
                  std::memory_order_relaxed);
    log_health(drive, before, s.health, s.setup);
    return true;
}

std::vector<std::pair<std::string, std::uint64_t>> Publisher::sequences() const {
    std::vector<std::pair<std::string, std::uint64_t>> out;
    for (std::size_t i = 0; i < last_.size(); ++i) {
        out.emplace_back(bus_.drives[i].name, last_[i].sequence);
    }
    return out;
}

void Publisher::continue_sequences(const std::vector<std::pair<std::string, std::uint64_t>>& sequences) {
    for (const auto& [name, sequence] : sequences) {
        if (const auto i = drive_index(name)) {
            last_[*i].sequence = sequence;
        }
    }
}

void Publisher::lease(std::size_t drive, const shm::LeaseStatus& lease) {
    last_.at(drive).lease = lease;
    publish(drive);
}

void Publisher::publish(std::size_t drive) {
    auto& s = last_[drive];
    ++s.sequence;  // every publication, poll cycle or lease change: subscribers wait on it
    s.published_ns = monotonic_ns(sys::now());
    auto sample = channels_->drives[drive]->loan();
    if (sample.has_error()) {
        log::warning(fmt::format("bus {}: no shared memory for a snapshot", bus_.name),
                     {.bus = bus_.name, .drive = bus_.drives[drive].name});
        return;
    }
    std::memcpy(static_cast<void*>(sample.value().get()), &s, sizeof s);
    sample.value().publish();
    ++publications_;
}

void Publisher::status(const master::BusStatus& bus, const IpcCounts& counts) {
    auto sample = channels_->status.loan();
    if (sample.has_error()) {
        return;
    }
    std::vector<shm::DriveHealth> health;
    health.reserve(health_.size());
    for (const auto h : health_) {
        health.push_back(to_shm(h));
    }
    auto& out = *sample.value().get();
    fill_status(bus_, bus, health,
                {.published_ns = monotonic_ns(std::chrono::steady_clock::now()), .daemon_pid = ::getpid()}, out);
    shm::assign(out.control_group, control_group_);
    for (std::size_t i = 0; i < last_.size() && i < out.drives.size(); ++i) {
        const auto& c = last_[i].comm_timeout;
        out.drives[i].comm_timeout_state = c.state;
        out.drives[i].comm_timeout_verdict = c.verdict;
        out.drives[i].comm_timeout_ms = c.timeout_ms;
    }
    out.counters.requests_served = counts.served;
    out.counters.queue_rejections += counts.queue_full;  // the bus's own refusals, and the intake's
    out.counters.lease_expiries = counts.lease_expiries;
    sample.value().publish();
    ++publications_;
}

namespace {

std::string hex(std::uint16_t value) {
    return fmt::format("0x{:04X}", value);
}

std::string name_of(const Profile& profile, std::uint16_t address) {
    const auto* r = profile.find(address);
    return r != nullptr ? r->name : hex(address);
}

// The selectors of the block at `address` ("F875-F879"), or of the block selector `address`
// belongs to.
std::string selectors_of(const Profile& profile, std::uint16_t address) {
    for (const auto& block : profile.indirect_blocks) {
        bool ours = block.address == address;
        for (const auto& name : block.selectors) {
            const auto* r = profile.find(std::string_view(name));
            ours = ours || (r != nullptr && r->address == address);
        }
        if (ours && !block.selectors.empty()) {
            return block.selectors.size() == 1 ? block.selectors.front()
                                               : block.selectors.front() + "-" + block.selectors.back();
        }
    }
    return "its block selectors";
}

// Why a set-up did not hold, and what to do, in one line.
std::string setup_problem(const config::DriveConfig& d, master::Health health, const master::SetupNote& note) {
    using Kind = master::SetupNote::Kind;
    const Profile& p = *d.profile;
    std::string why;
    switch (note.kind) {
    case Kind::None: why = "its set-up did not hold"; break;
    case Kind::Refused:
        why = note.exception != 0 ? fmt::format("it refused {} (exception {})", name_of(p, note.reg), note.exception)
                                  : fmt::format("no valid reply to the set-up of {}", name_of(p, note.reg));
        break;
    case Kind::ReadBack:
        why = fmt::format("{} was written {} and reads {}", name_of(p, note.reg), note.wanted, note.held);
        break;
    case Kind::BlockDiffers:
        why = fmt::format("slot {} of the block at {} reads {} where {} reads {}", note.slot, hex(note.block),
                          note.held, name_of(p, note.reg), note.wanted);
        break;
    case Kind::NotApplied: why = fmt::format("{} written", selectors_of(p, note.reg)); break;
    case Kind::CannotTell:
        why = fmt::format(
            "{} written; the block at {} does not yet tell whether the drive applies them (its "
            "values are the same either way), tried again",
            selectors_of(p, note.block), hex(note.block));
        break;
    }
    const std::string selectors = selectors_of(p, note.kind == Kind::NotApplied ? note.reg : note.block);
    if (health == master::Health::AwaitingReset) {
        return fmt::format(
            "{}: the drive applies {} only after a reset: power-cycle it (or reset it after a "
            "fault). Until then nothing is polled and requests through its blocks are refused",
            why, selectors);
    }
    const bool after_reset = std::ranges::any_of(p.indirect_blocks, &IndirectBlock::selectors_after_reset);
    return fmt::format("{}; not polled, set up again with back-off{}", why,
                       note.kind == Kind::BlockDiffers && after_reset
                           ? fmt::format(" (the drive applies {} only after a reset: if they were changed "
                                         "since it was last powered up, power-cycle it)",
                                         selectors)
                           : std::string());
}

}  // namespace

// Once per drive while this bus runs: what its own Modbus time-out is, a warning when it is off,
// may fire between drivebusd's requests, or could not be read or written as configured.
void Publisher::log_comm_timeout(std::size_t drive, const master::CommTimeoutNote& note) {
    if (comm_timeout_logged_[drive]) {
        return;
    }
    const auto& d = bus_.drives[drive];
    const auto line = master::comm_timeout_line(bus_, d, note);
    if (!line) {
        return;
    }
    comm_timeout_logged_[drive] = true;
    log::write(line->warning ? log::Level::Warning : log::Level::Info, line->text, {.bus = bus_.name, .drive = d.name});
}

void Publisher::log_health(std::size_t drive, master::Health before, master::Health now,
                           const master::SetupNote& note) {
    const auto& d = bus_.drives[drive];
    const std::string key = bus_.name + "/" + d.name;
    const log::Fields fields{.bus = bus_.name, .drive = d.name};
    if (now == master::Health::Absent) {
        absent_log_.write(log::Level::Warning, key,
                          fmt::format("bus {} drive {} (address {}): absent, no reply after every retry; probing "
                                      "with back-off",
                                      bus_.name, d.name, d.address),
                          fields);
    } else if (now == master::Health::Unconfigured) {
        log::error(fmt::format("bus {} drive {}: unconfigured: {}", bus_.name, d.name, setup_problem(d, now, note)),
                   fields);
    } else if (now == master::Health::AwaitingReset) {
        log::warning(
            fmt::format("bus {} drive {}: awaiting a reset: {}", bus_.name, d.name, setup_problem(d, now, note)),
            fields);
    } else if (now == master::Health::Online && before == master::Health::Absent) {
        absent_log_.reset(key);  // the absence is over: the next one is logged at once
        log::notice(fmt::format("bus {} drive {}: answering again", bus_.name, d.name), fields);
    } else if (now == master::Health::Online &&
               (before == master::Health::Unconfigured || before == master::Health::AwaitingReset)) {
        log::notice(fmt::format("bus {} drive {}: its set-up holds and its blocks return what drivebusd selected: "
                                "polled",
                                bus_.name, d.name),
                    fields);
    }
}

}  // namespace drivebus::ipc
