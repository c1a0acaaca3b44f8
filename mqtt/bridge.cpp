// SPDX-License-Identifier: Apache-2.0
#include <poll.h>

#include <algorithm>

#include "bridge.hpp"
#include "bridge_links.hpp"
#include "log/log.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

constexpr auto kIdleWake = 1s;

CommanderLimits limits_of(const Limits& limits) {
    return CommanderLimits{.max_payload = limits.max_payload,
                           .command_queue = limits.command_queue,
                           .max_command_age = limits.max_command_age};
}

}  // namespace

Bridge::Bridge(const Config& config)
    : config_(config), topics_(config.node), commander_(limits_of(config.limits), fleet_) {
    for (const auto& b : config_.buses) {
        auto link = std::make_unique<BusLink>();
        link->settings = b;
        link->cadence = Cadence(b.period, 0.0);
        buses_.push_back(std::move(link));
    }
    link_ = std::make_unique<BrokerLink>(
        config_, BrokerLink::Callbacks{.connected = [this] { on_connected(); },
                                       .message = [this](std::string_view t, std::string_view p,
                                                         bool retained) { on_message(t, p, retained); }});
}

Bridge::~Bridge() {
    stop();
    link_.reset();
    // The buses' subscriptions call back into this object and into their drive links: ended
    // first, then the links go (a command's completions still pending go uncalled with them).
    for (auto& b : buses_) {
        for (auto& d : b->drives) {
            d->subscription.reset();
        }
    }
    buses_.clear();
}

void Bridge::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake();
}

// On the network thread.
void Bridge::on_connected() {
    {
        std::lock_guard lock(mutex_);
        republish_ = true;
    }
    wake();
}

void Bridge::connect_bus(BusLink& b, Clock::time_point now) {
    ConnectOptions options;
    options.application = "drivebus-mqtt";
    options.delivery = Delivery::Dispatch;  // on the bridge's loop: no thread of the library's
    auto bus = Bus::connect(b.settings.name, options);
    std::vector<std::shared_ptr<DriveLink>> drives;
    std::string error;
    if (bus) {
        auto status = bus->status(2s);
        if (!status) {
            error = status.error().message;
        } else {
            const std::size_t count = std::min<std::size_t>(status->drive_count, status->drives.size());
            for (std::size_t i = 0; i < count; ++i) {
                const std::string name(shm::view(status->drives[i].name));
                auto drive = bus->drive(name);
                if (!drive) {
                    error = drive.error().message;
                    break;
                }
                const auto settings = b.settings.drive(name);
                drives.push_back(
                    std::make_shared<DriveLink>(DriveLink{.settings = settings,
                                                          .drive = std::move(*drive),
                                                          .subscription = {},
                                                          .latest = {},
                                                          .fresh = false,
                                                          .cadence = Cadence(settings.period, settings.deadband)}));
            }
        }
    } else {
        error = bus.error().message;
    }
    if (!error.empty()) {
        if (b.retry.failures() == 0) {
            log::warning("bus " + b.settings.name + ": " + error + "; retrying with back-off",
                         {.bus = b.settings.name});
        }
        b.next_attempt = now + b.retry.next(0.5);
        if (b.last_error != error) {
            b.last_error = error;
            b.cadence.again();
        }
        return;
    }
    for (const auto& d : b.settings.drives) {
        if (std::ranges::none_of(drives, [&](const auto& l) { return l->settings.name == d.name; })) {
            log::warning("bus " + b.settings.name + ": drivebusd has no drive '" + d.name + "' (configured here)",
                         {.bus = b.settings.name});
        }
    }
    b.retry.reset();
    b.last_error.clear();
    for (auto& d : drives) {
        DriveLink* raw = d.get();
        // In dispatch(), on the loop's thread: the loop publishes what changed after it.
        d->subscription = d->drive.on_snapshot([raw](const shm::DriveSnapshot& s) {
            raw->latest = s;
            raw->fresh = true;
        });
    }
    log::notice("bus " + b.settings.name + ": bridging " + std::to_string(drives.size()) + " drives",
                {.bus = b.settings.name});
    b.bus.emplace(std::move(*bus));
    b.drives = std::move(drives);
    b.cadence.again();
}

void Bridge::publish_bus(BusLink& b, Clock::time_point now, bool force) {
    Json status;
    if (!b.bus) {
        status = bus_unreachable(b.settings.name, b.last_error);
    } else {
        auto s = b.bus->status();
        if (!s) {
            return;
        }
        status = bus_status(*s, b.bus->daemon_alive());
    }
    if (!b.cadence.due(status, now, force)) {
        return;
    }
    if (link_->publish(topics_.bus_status(b.settings.name), status.dump(), 0, true)) {
        b.cadence.published(std::move(status), now);
    }
}

void Bridge::publish_drive(BusLink& b, DriveLink& d, Clock::time_point now, bool force) {
    if (!d.latest || (!d.fresh && !force && !d.cadence.due_by_time(now))) {
        return;
    }
    auto state = drive_state(*d.latest, d.drive.profile());
    if (!d.cadence.due(state, now, force)) {
        d.fresh = false;
        return;
    }
    // Not taken (the broker stalls): still fresh, tried again next round.
    if (link_->publish(topics_.state(b.settings.name, d.settings.name), state.dump(), 0, true)) {
        d.cadence.published(std::move(state), now);
        d.fresh = false;
        ++states_published_;
    }
}

Clock::time_point Bridge::next_deadline(Clock::time_point now) const {
    auto next = now + kIdleWake;
    for (const auto& b : buses_) {
        if (!b->bus) {
            next = std::min(next, b->next_attempt);
        }
        next = std::min(next, b->cadence.next());
        for (const auto& d : b->drives) {
            next = std::min(next, d->cadence.next());
        }
    }
    return std::max(next, now + 10ms);
}

void Bridge::run() {
    link_->start();
    std::vector<pollfd> fds;
    for (;;) {
        fds.assign(1, pollfd{.fd = wake_.fd(), .events = POLLIN, .revents = 0});
        for (const auto& b : buses_) {
            if (b->bus) {
                fds.push_back(pollfd{.fd = b->bus->descriptor(), .events = POLLIN, .revents = 0});
            }
        }
        const auto before = Clock::now();
        const auto wait = std::chrono::ceil<std::chrono::milliseconds>(next_deadline(before) - before);
        (void)::poll(fds.data(), fds.size(), static_cast<int>(wait.count()));  // EINTR: round again
        wake_.drain();
        for (const auto& b : buses_) {
            if (b->bus) {
                b->bus->dispatch();  // snapshots, statuses, commands' answers; returns at once if none
            }
        }
        bool republish = false;
        {
            std::lock_guard lock(mutex_);
            if (stopping_) {
                break;
            }
            republish = std::exchange(republish_, false);
        }
        take_messages();
        const auto now = Clock::now();
        for (auto& b : buses_) {
            if (!b->bus && now >= b->next_attempt) {
                connect_bus(*b, now);
            }
            if (!link_->connected()) {
                continue;
            }
            publish_bus(*b, now, republish);
            for (auto& d : b->drives) {
                publish_drive(*b, *d, now, republish);
            }
        }
    }
    link_->stop();
    const auto c = link_->counters();
    const auto& commands = commander_.counters();
    log::notice("stopped: " + std::to_string(states_published_) + " states published, " +
                std::to_string(commands.commands) + " commands carried out, " +
                std::to_string(commands.commands_refused) + " refused, " + std::to_string(c.dropped) +
                " messages dropped, " + std::to_string(c.connections) + " broker connections");
}

}  // namespace drivebus::mqtt