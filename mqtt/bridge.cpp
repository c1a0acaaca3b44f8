// SPDX-License-Identifier: Apache-2.0
#include "bridge.hpp"

#include <algorithm>

#include "log/log.hpp"
#include "mqtt/command.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

constexpr auto kIdleWake = 1s;
constexpr auto kBusRetryShortest = 1s;
constexpr auto kBusRetryLongest = 30s;

std::string reason_of(ErrorKind kind) {
    std::string text(to_string(kind));
    std::ranges::replace(text, ' ', '_');
    return text;
}

// A command stopped part way says what it did before: that is not undone.
std::string with_done(const std::string& message, const std::string& done_so_far) {
    return done_so_far.empty() ? message : message + " (" + done_so_far + " done before: not undone)";
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

struct Bridge::DriveLink {
    DriveSettings settings;
    Drive drive;
    Subscription subscription;
    // The newest snapshot, handed over by libdrivebus's thread (under Bridge::mutex_).
    std::optional<shm::DriveSnapshot> latest;
    bool fresh = false;
    // Owned by the publishing thread.
    Json published;
    Clock::time_point published_at{};
    bool pending = true;  // to publish even without change (first time, after a reconnect)
};

struct Bridge::BusLink {
    BusSettings settings;
    std::optional<Bus> bus;
    Subscription status_subscription;
    std::vector<std::shared_ptr<DriveLink>> drives;  // set once connected (under Bridge::mutex_)
    Backoff retry{kBusRetryShortest, kBusRetryLongest};
    Clock::time_point next_attempt{};
    std::string last_error;
    Json published;
    Clock::time_point published_at{};
    bool pending = true;
};

Bridge::Bridge(const Config& config) : config_(config), topics_(config.node) {
    for (const auto& b : config_.buses) {
        auto link = std::make_unique<BusLink>();
        link->settings = b;
        buses_.push_back(std::move(link));
    }
    link_ = std::make_unique<BrokerLink>(
        config_, BrokerLink::Callbacks{.connected = [this] { on_connected(); },
                                       .message = [this](std::string_view t, std::string_view p,
                                                         bool retained) { on_message(t, p, retained); }});
}

Bridge::~Bridge() {
    stop();
    if (worker_.joinable()) {
        worker_.join();
    }
    link_.reset();
    // The buses' subscriptions call back into this object (mutex_, wake_) and into their drive
    // links: ended first (reset() returns once no callback runs), then the links go.
    for (auto& b : buses_) {
        for (auto& d : b->drives) {
            d->subscription.reset();
        }
        b->status_subscription.reset();
    }
    buses_.clear();
}

void Bridge::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    jobs_ready_.notify_all();
}

void Bridge::on_connected() {
    {
        std::lock_guard lock(mutex_);
        republish_ = true;
    }
    wake_.notify_all();
}

std::shared_ptr<Bridge::DriveLink> Bridge::find(std::string_view bus, std::string_view drive,
                                                const BusLink** on_bus) const {
    for (const auto& b : buses_) {
        if (b->settings.name != bus) {
            continue;
        }
        if (on_bus != nullptr) {
            *on_bus = b.get();
        }
        for (const auto& d : b->drives) {
            if (d->settings.name == drive) {
                return d;
            }
        }
    }
    return nullptr;
}

void Bridge::refuse(const Topics::Target& target, const Json& id, std::string_view reason, std::string_view message) {
    {
        std::lock_guard lock(mutex_);
        ++counters_.commands_refused;
    }
    if (log::enabled(log::Level::Debug)) {
        log::debug("command " + id.dump() + " to " + target.bus + "/" + target.drive +
                       " refused: " + std::string(reason) + ": " + std::string(message),
                   {.bus = target.bus, .drive = target.drive});
    }
    link_->publish(topics_.result(target.bus, target.drive), result_error(id, reason, message).dump(), 1, false);
}

// On the network thread: refuses at once what can be refused without drivebusd, queues the rest.
void Bridge::on_message(std::string_view topic, std::string_view payload, bool retained) {
    const auto received = std::chrono::system_clock::now();
    const auto arrived = Clock::now();
    const auto target = topics_.parse_set(topic);
    if (!target) {
        return;
    }
    if (payload.size() > config_.limits.max_payload) {
        refuse(*target, nullptr, "too_large",
               "payload of " + std::to_string(payload.size()) + " bytes is larger than the limit of " +
                   std::to_string(config_.limits.max_payload));
        return;
    }
    const auto parsed = parse_command(payload, config_.limits.max_payload);
    if (!parsed) {
        refuse(*target, parsed.error().id, "malformed", parsed.error().message);
        return;
    }
    // The broker hands a retained command to every new subscription, however old: the bridge's
    // every reconnection would carry it out again.
    if (retained) {
        refuse(*target, parsed->id, "retained",
               "a retained command is never carried out: publish commands without the retain flag, and clear "
               "this one (an empty retained message on the same topic)");
        return;
    }
    std::unique_lock lock(mutex_);
    const BusLink* bus = nullptr;
    const auto drive = find(target->bus, target->drive, &bus);
    if (bus == nullptr) {
        lock.unlock();
        refuse(*target, parsed->id, "unknown_bus", "this bridge has no bus '" + target->bus + "'");
        return;
    }
    if (!drive) {
        lock.unlock();
        refuse(*target, parsed->id, "unknown_drive",
               "bus '" + target->bus + "' has no drive '" + target->drive + "' (or drivebusd is not reachable)");
        return;
    }
    if (!drive->settings.commands) {
        lock.unlock();
        refuse(*target, parsed->id, "commands_disabled",
               "commands are not enabled for drive '" + target->drive + "' (commands = true in its [[bus.drive]])");
        return;
    }
    if (jobs_.size() >= config_.limits.command_queue) {
        ++counters_.commands_queue_full;
        lock.unlock();
        refuse(*target, parsed->id, "busy",
               std::to_string(config_.limits.command_queue) + " commands already wait: try again later");
        return;
    }
    jobs_.push_back(Job{target->bus, target->drive, std::string(payload), received, arrived});
    lock.unlock();
    jobs_ready_.notify_one();
}

void Bridge::work() {
    for (;;) {
        Job job;
        {
            std::unique_lock lock(mutex_);
            jobs_ready_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
            if (stopping_) {
                return;
            }
            job = std::move(jobs_.front());
            jobs_.pop_front();
            ++counters_.commands;
        }
        carry_out(job);
    }
}

// The lease is renewed here and nowhere else: by the writes a command makes, by its heartbeat,
// and by the keep-alive each other command adds. No timer renews it, so a commander that goes
// away lets it run out, and drivebusd applies the drive's fallback.
void Bridge::carry_out(const Job& job) {
    const Topics::Target target{job.bus, job.drive};
    const auto command = parse_command(job.payload, config_.limits.max_payload);
    std::shared_ptr<DriveLink> drive;
    {
        std::lock_guard lock(mutex_);
        drive = find(job.bus, job.drive);
    }
    if (!command || !drive) {
        return;
    }
    const auto actions = plan(*command, drive->drive.profile());
    if (!actions) {
        refuse(target, command->id, "invalid", actions.error());
        return;
    }
    bool renewed = false;
    std::string done_so_far;
    for (const auto& a : *actions) {
        // Checked before each action: a command that has run out of time acts no further.
        const auto left =
            time_left(command->freshness, job.received, Clock::now() - job.arrived, config_.limits.max_command_age);
        if (!left) {
            refuse(target, command->id, left.error().reason, with_done(left.error().message, done_so_far));
            return;
        }
        std::expected<void, Error> done;
        switch (a.kind) {
        case Action::Kind::Write: {
            const std::array<std::uint16_t, 1> word{a.raw};
            // The command's time left bounds the write too: held up in drivebusd's queue (a slow
            // or late drive ahead of it) past that, drivebusd drops it rather than send it late.
            done = drive->drive.write(a.address, word, write_options(*left));
            break;
        }
        case Action::Kind::KeepAlive:
            done = drive->drive.keep_alive();
            renewed = true;
            break;
        case Action::Kind::Release:
            done = drive->drive.release_control();
            renewed = true;
            break;
        }
        if (!done) {
            if (log::enabled(log::Level::Debug)) {
                log::debug(
                    "command " + command->id.dump() + " to " + job.bus + "/" + job.drive + ": " + done.error().message,
                    {.bus = job.bus, .drive = job.drive});
            }
            const std::string what = a.kind == Action::Kind::Write ? "write " + a.name + ": " : std::string();
            link_->publish(topics_.result(job.bus, job.drive),
                           result_error(command->id, reason_of(done.error().kind),
                                        with_done(what + done.error().message, done_so_far))
                               .dump(),
                           1, false);
            return;
        }
        done_so_far +=
            (done_so_far.empty() ? "" : ", ") +
            (a.kind == Action::Kind::Write ? "write " + a.name
                                           : std::string(a.kind == Action::Kind::KeepAlive ? "heartbeat" : "release"));
    }
    if (!renewed) {
        // A write to a register outside the lease's own does not renew it: the command's arrival does.
        // NotPermitted when the bridge holds no lease on the drive: nothing to renew, no error.
        [[maybe_unused]] const auto kept = drive->drive.keep_alive();
    }
    if (log::enabled(log::Level::Debug)) {
        log::debug("command " + command->id.dump() + " to " + job.bus + "/" + job.drive + ": done",
                   {.bus = job.bus, .drive = job.drive});
    }
    link_->publish(topics_.result(job.bus, job.drive), result_ok(command->id).dump(), 1, false);
}

void Bridge::connect_bus(BusLink& b, Clock::time_point now) {
    ConnectOptions options;
    options.application = "drivebus-mqtt";
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
                drives.push_back(std::make_shared<DriveLink>(DriveLink{.settings = b.settings.drive(name),
                                                                       .drive = std::move(*drive),
                                                                       .subscription = {},
                                                                       .latest = {},
                                                                       .fresh = false,
                                                                       .published = {},
                                                                       .published_at = {},
                                                                       .pending = true}));
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
            b.pending = true;
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
        d->subscription = d->drive.on_snapshot([this, raw](const shm::DriveSnapshot& s) {
            {
                std::lock_guard lock(mutex_);
                raw->latest = s;
                raw->fresh = true;
                dirty_ = true;
            }
            wake_.notify_all();
        });
    }
    b.status_subscription = bus->on_status([this](const shm::BusStatus&) {
        {
            std::lock_guard lock(mutex_);
            dirty_ = true;
        }
        wake_.notify_all();
    });
    log::notice("bus " + b.settings.name + ": bridging " + std::to_string(drives.size()) + " drives",
                {.bus = b.settings.name});
    std::lock_guard lock(mutex_);
    b.bus.emplace(std::move(*bus));
    b.drives = std::move(drives);
    b.pending = true;
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
    const bool due = now - b.published_at >= b.settings.period;
    if (!force && !b.pending && !due && !significant_change(b.published, status, 0.0)) {
        return;
    }
    if (link_->publish(topics_.bus_status(b.settings.name), status.dump(), 0, true)) {
        b.published = std::move(status);
        b.published_at = now;
        b.pending = false;
    }
}

void Bridge::publish_drive(BusLink& b, DriveLink& d, Clock::time_point now, bool force) {
    std::optional<shm::DriveSnapshot> snapshot;
    {
        std::lock_guard lock(mutex_);
        if (!d.latest) {
            return;
        }
        const bool due = now - d.published_at >= d.settings.period;
        if (!d.fresh && !force && !d.pending && !due) {
            return;
        }
        snapshot = d.latest;
        d.fresh = false;
    }
    auto state = drive_state(*snapshot, d.drive.profile());
    const bool due = now - d.published_at >= d.settings.period;
    if (!force && !d.pending && !due && !significant_change(d.published, state, d.settings.deadband)) {
        return;
    }
    if (link_->publish(topics_.state(b.settings.name, d.settings.name), state.dump(), 0, true)) {
        d.published = std::move(state);
        d.published_at = now;
        d.pending = false;
        std::lock_guard lock(mutex_);
        ++counters_.states_published;
    }
}

Clock::time_point Bridge::next_deadline(Clock::time_point now) const {
    auto next = now + kIdleWake;
    for (const auto& b : buses_) {
        if (!b->bus) {
            next = std::min(next, b->next_attempt);
        }
        next = std::min(next, b->published_at + b->settings.period);
        for (const auto& d : b->drives) {
            next = std::min(next, d->published_at + d->settings.period);
        }
    }
    return std::max(next, now + 10ms);
}

void Bridge::run() {
    worker_ = std::thread([this] { work(); });
    link_->start();
    for (;;) {
        bool republish = false;
        {
            std::unique_lock lock(mutex_);
            const auto deadline = next_deadline(Clock::now());
            wake_.wait_until(lock, deadline, [this] { return stopping_ || republish_ || dirty_; });
            if (stopping_) {
                break;
            }
            republish = std::exchange(republish_, false);
            dirty_ = false;
        }
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
    if (worker_.joinable()) {
        worker_.join();
    }
    link_->stop();
    const auto c = link_->counters();
    log::notice("stopped: " + std::to_string(counters_.states_published) + " states published, " +
                std::to_string(counters_.commands) + " commands carried out, " +
                std::to_string(counters_.commands_refused) + " refused, " + std::to_string(c.dropped) +
                " messages dropped, " + std::to_string(c.connections) + " broker connections");
}

}  // namespace drivebus::mqtt
