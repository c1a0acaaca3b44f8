// SPDX-License-Identifier: Apache-2.0
#include "mqtt/relay.hpp"

#include <algorithm>
#include <array>

#include "mqtt/payload.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

CommanderLimits limits_of(const Limits& limits) {
    return CommanderLimits{.max_payload = limits.max_payload,
                           .command_queue = limits.command_queue,
                           .max_command_age = limits.max_command_age};
}

// Rounded down: the deadline is counted again from libdrivebus's call, a little later.
WriteOptions write_options(std::optional<std::chrono::nanoseconds> left) {
    WriteOptions options;
    if (left) {
        options.deadline = std::chrono::floor<Milliseconds>(*left);
    }
    return options;
}

}  // namespace

Relay::Relay(const Config& config, Broker& broker, Daemon& daemon, Notes notes)
    : config_(config),
      broker_(broker),
      daemon_(daemon),
      notes_(std::move(notes)),
      topics_(config.node),
      commander_(limits_of(config.limits), fleet_) {
    for (const auto& b : config_.buses) {
        buses_.push_back(std::make_unique<BusLink>(BusLink{.settings = b,
                                                           .cadence = Cadence(b.period, 0.0),
                                                           .retry = Backoff(kBusRetryShortest, kBusRetryLongest),
                                                           .next_attempt = {},
                                                           .last_error = {},
                                                           .port = {},
                                                           .status_due = {},
                                                           .reached = false,
                                                           .drives = {}}));
    }
}

// The drives' ports first (their sinks point into their links), then the buses' (a request's
// completion still pending goes uncalled with them).
Relay::~Relay() {
    for (auto& b : buses_) {
        b->drives.clear();
        b->port.reset();
    }
}

void Relay::note(RelayNote::Level level, std::string bus, std::string text) const {
    if (notes_) {
        notes_(RelayNote{.level = level, .bus = std::move(bus), .drive = {}, .text = std::move(text)});
    }
}

std::vector<int> Relay::descriptors() const {
    std::vector<int> fds;
    for (const auto& b : buses_) {
        if (b->port) {
            fds.push_back(b->port->descriptor());
        }
    }
    return fds;
}

void Relay::dispatch(Time now) {
    now_ = now;
    for (const auto& b : buses_) {
        if (b->port) {
            b->port->dispatch();
        }
    }
}

void Relay::turn(Time now, bool republish) {
    now_ = now;
    for (auto& b : buses_) {
        if (!b->port && now >= b->next_attempt) {
            attempt(*b, now);
        }
        if (b->port && !b->reached) {
            reach(*b, now);
        }
        if (!broker_.connected()) {
            continue;
        }
        publish_bus(*b, now, republish);
        for (auto& d : b->drives) {
            publish_drive(*b, *d, now, republish);
        }
    }
}

Relay::Time Relay::next_deadline(Time now) const {
    auto next = now + kIdleTurn;
    // Only what has something to publish counts (a cadence never published is due at once):
    // a bus not reached yet, a drive with no snapshot, or no broker to take them would turn the
    // loop without end.
    const bool publishing = broker_.connected();
    for (const auto& b : buses_) {
        if (!b->port) {
            next = std::min(next, b->next_attempt);
        } else if (!b->reached) {
            next = std::min(next, b->status_due);
        }
        if (!publishing) {
            continue;
        }
        if (b->reached || !b->last_error.empty()) {
            next = std::min(next, b->cadence.next());
        }
        for (const auto& d : b->drives) {
            if (d->latest) {
                next = std::min(next, d->cadence.next());
            }
        }
    }
    return std::max(next, now);
}

void Relay::attempt(BusLink& b, Time now) {
    ++counters_.bus_attempts;
    auto port = daemon_.connect(b.settings.name);
    if (!port) {
        fail(b, std::move(port.error()), now);
        return;
    }
    b.port = std::move(*port);
    b.status_due = now + kFirstStatusWait;
    b.port->dispatch();  // a status already there, before the descriptor is watched
}

// Connected: once its first status has come, its drives.
void Relay::reach(BusLink& b, Time now) {
    const auto status = b.port->status();
    if (!status) {
        if (now >= b.status_due) {
            fail(b, "drivebusd sent no status of bus '" + b.settings.name + "' within 2 s", now);
        }
        return;
    }
    std::vector<std::unique_ptr<DriveLink>> drives;
    const std::size_t count = std::min<std::size_t>(status->drive_count, status->drives.size());
    for (std::size_t i = 0; i < count; ++i) {
        const std::string name(shm::view(status->drives[i].name));
        const auto settings = b.settings.drive(name);
        auto link = std::make_unique<DriveLink>(DriveLink{.settings = settings,
                                                          .cadence = Cadence(settings.period, settings.deadband),
                                                          .latest = {},
                                                          .fresh = false,
                                                          .port = {}});
        DriveLink* raw = link.get();
        // In dispatch(): the next turn publishes what changed.
        auto port = b.port->drive(name, [raw](const shm::DriveSnapshot& s) {
            raw->latest = s;
            raw->fresh = true;
        });
        if (!port) {
            drives.clear();  // their ports end before the bus's
            fail(b, std::move(port.error()), now);
            return;
        }
        link->port = std::move(*port);
        drives.push_back(std::move(link));
    }
    for (const auto& d : b.settings.drives) {
        if (std::ranges::none_of(drives, [&](const auto& l) { return l->settings.name == d.name; })) {
            note(RelayNote::Level::Warning, b.settings.name,
                 "bus " + b.settings.name + ": drivebusd has no drive '" + d.name + "' (configured here)");
        }
    }
    b.retry.reset();
    b.last_error.clear();
    b.reached = true;
    b.drives = std::move(drives);
    b.cadence.again();
    note(RelayNote::Level::Notice, b.settings.name,
         "bus " + b.settings.name + ": bridging " + std::to_string(b.drives.size()) + " drives");
}

void Relay::fail(BusLink& b, std::string error, Time now) {
    b.port.reset();
    if (b.retry.failures() == 0) {
        note(RelayNote::Level::Warning, b.settings.name,
             "bus " + b.settings.name + ": " + error + "; retrying with back-off");
    }
    b.next_attempt = now + b.retry.next();  // no spread: drivebusd is on this board, not shared
    if (b.last_error != error) {
        b.last_error = std::move(error);
        b.cadence.again();
    }
}

void Relay::publish_bus(BusLink& b, Time now, bool force) {
    Json status;
    if (!b.reached) {
        // Connected and waiting for the first status: what it was before, until it comes.
        if (b.last_error.empty()) {
            return;
        }
        status = bus_unreachable(b.settings.name, b.last_error);
    } else {
        auto s = b.port->status();
        if (!s) {
            return;
        }
        status = bus_status(*s, b.port->daemon_alive());
    }
    if (!b.cadence.due(status, now, force)) {
        return;
    }
    if (broker_.publish(topics_.bus_status(b.settings.name), status.dump(), 0, true)) {
        b.cadence.published(std::move(status), now);
    }
}

void Relay::publish_drive(BusLink& b, DriveLink& d, Time now, bool force) {
    if (!d.latest || (!d.fresh && !force && !d.cadence.due_by_time(now))) {
        return;
    }
    auto state = drive_state(*d.latest, d.port->profile());
    if (!d.cadence.due(state, now, force)) {
        d.fresh = false;
        return;
    }
    // Not taken (the broker stalls): still fresh, tried again next round.
    if (broker_.publish(topics_.state(b.settings.name, d.settings.name), state.dump(), 0, true)) {
        d.cadence.published(std::move(state), now);
        d.fresh = false;
        ++counters_.states_published;
    }
}

bool Relay::Fleet::has_bus(std::string_view bus) const {
    return std::ranges::any_of(relay_.buses_, [&](const auto& b) { return b->settings.name == bus; });
}

std::optional<Roster::Drive> Relay::Fleet::drive(std::string_view bus, std::string_view drive) const {
    const DriveLink* d = relay_.find(bus, drive);
    if (d == nullptr) {
        return std::nullopt;
    }
    return Drive{.commands = d->settings.commands, .profile = d->port->profile()};
}

Relay::DriveLink* Relay::find(std::string_view bus, std::string_view drive) const {
    for (const auto& b : buses_) {
        if (b->settings.name != bus) {
            continue;
        }
        for (const auto& d : b->drives) {
            if (d->settings.name == drive) {
                return d.get();
            }
        }
    }
    return nullptr;
}

void Relay::message(const Topics::Target& target, std::string_view payload, bool retained, WallTime received,
                    Time arrived) {
    carry(commander_.message(target, payload, retained, received, arrived));
}

void Relay::carry(const CommanderEffects& effects) {
    if (notes_) {
        for (const auto& n : effects.debug) {
            notes_(RelayNote{.level = RelayNote::Level::Debug, .bus = n.bus, .drive = n.drive, .text = n.text});
        }
    }
    for (const auto& r : effects.results) {
        broker_.publish(topics_.result(r.bus, r.drive), r.payload.dump(), 1, false);
    }
    for (const auto& s : effects.steps) {
        DriveLink* d = find(s.bus, s.drive);
        const std::uint64_t ticket = s.ticket;
        auto after = [this, ticket](const std::expected<void, Error>& done) {
            if (ticket != 0) {
                carry(commander_.done(ticket, done, now_));
            }
        };
        if (d == nullptr) {  // the Commander asks only for drives the Fleet has
            Error gone;
            gone.kind = ErrorKind::NoSuchBus;
            gone.message = "bus '" + s.bus + "' has no drive '" + s.drive + "' any more";
            after(std::unexpected(std::move(gone)));
            continue;
        }
        switch (s.action.kind) {
        case Action::Kind::Write:
            d->port->write(s.action.address, s.action.raw, write_options(s.deadline), after);
            break;
        case Action::Kind::KeepAlive: d->port->keep_alive(after); break;
        case Action::Kind::Release: d->port->release_control(after); break;
        }
    }
}

}  // namespace drivebus::mqtt
