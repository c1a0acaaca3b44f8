#include "ipc/publisher.hpp"

#include <algorithm>
#include <cstring>
#include <fmt/format.h>

#include "iceoryx_posh/popo/publisher.hpp"
#include "ipc/convert.hpp"
#include "ipc/service.hpp"
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
    explicit Channels(const config::BusConfig& bus)
        : status(service(bus.name, shm::kStatusEvent), history_one()) {
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
      health_(bus.drives.size(), master::Health::Unknown) {
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
    fill_snapshot(s, last_[drive]);
    last_[drive].sequence = sequence;
    last_[drive].lease = lease;
    publish(drive);
    const auto before = health_[drive];
    if (before == s.health) {
        return false;
    }
    health_[drive] = s.health;
    online_.store(static_cast<std::size_t>(std::ranges::count(health_, master::Health::Online)),
                  std::memory_order_relaxed);
    log_health(drive, before, s.health);
    return true;
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
        log::warning(fmt::format("bus {}: no shared memory for a snapshot", bus_.name));
        return;
    }
    std::memcpy(static_cast<void*>(sample.value().get()), &s, sizeof s);
    sample.value().publish();
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
    fill_status(bus_, bus, health, out);
    shm::assign(out.control_group, control_group_);
    out.counters.requests_served = counts.served;
    out.counters.queue_rejections += counts.queue_full;  // the bus's own refusals, and the intake's
    out.counters.lease_expiries = counts.lease_expiries;
    sample.value().publish();
}

void Publisher::log_health(std::size_t drive, master::Health before, master::Health now) {
    const auto& d = bus_.drives[drive];
    const std::string key = bus_.name + "/" + d.name;
    if (now == master::Health::Absent) {
        absent_log_.write(log::Level::Warning, key,
                          fmt::format("bus {} drive {} (address {}): absent, no reply after every retry; probing "
                                      "with back-off",
                                      bus_.name, d.name, d.address));
    } else if (now == master::Health::Unconfigured && before != master::Health::Unconfigured) {
        log::error(fmt::format("bus {} drive {}: its set-up (the selectors of its indirect blocks) failed or did not "
                               "read back as written; not polled, set up again with back-off",
                               bus_.name, d.name));
    } else if (now == master::Health::Online && before == master::Health::Absent) {
        log::notice(fmt::format("bus {} drive {}: answering again", bus_.name, d.name));
    }
}

}  // namespace drivebus::ipc
