// SPDX-License-Identifier: Apache-2.0
// Commands from the broker: refused at once on the network thread where drivebusd is not
// needed, queued otherwise, and carried out one at a time on the bridge's loop, each action a
// libdrivebus request answered by callback.
#include <algorithm>
#include <array>

#include "bridge.hpp"
#include "bridge_links.hpp"
#include "log/log.hpp"
#include "mqtt/command.hpp"

namespace drivebus::mqtt {
namespace {

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
    wake();
}

struct Bridge::Running {
    Job job;
    Command command;
    // Weak: the requests' completions hold this Running, and a DriveLink holds the Bus whose
    // pending completions they are (a cycle would keep the Bus from ever going).
    std::weak_ptr<DriveLink> drive;
    std::vector<Action> actions;
    std::size_t next = 0;
    bool renewed = false;
    std::string done_so_far;
};

void Bridge::start_command() {
    while (!running_) {
        Job job;
        {
            std::lock_guard lock(mutex_);
            if (jobs_.empty()) {
                return;
            }
            job = std::move(jobs_.front());
            jobs_.pop_front();
            ++counters_.commands;
        }
        const Topics::Target target{job.bus, job.drive};
        auto command = parse_command(job.payload, config_.limits.max_payload);
        std::shared_ptr<DriveLink> drive;
        {
            std::lock_guard lock(mutex_);
            drive = find(job.bus, job.drive);
        }
        if (!command || !drive) {
            continue;
        }
        auto actions = plan(*command, drive->drive.profile());
        if (!actions) {
            refuse(target, command->id, "invalid", actions.error());
            continue;
        }
        running_ = std::make_shared<Running>(Running{.job = std::move(job),
                                                     .command = std::move(*command),
                                                     .drive = std::move(drive),
                                                     .actions = std::move(*actions),
                                                     .next = 0,
                                                     .renewed = false,
                                                     .done_so_far = {}});
        step(running_);
    }
}

// The lease is renewed here and nowhere else: by the writes a command makes, by its heartbeat,
// and by the keep-alive each other command adds. No timer renews it, so a commander that goes
// away lets it run out, and drivebusd applies the drive's fallback. Each action is a request
// answered by callback on the loop's thread, the next one sent from there.
void Bridge::step(const std::shared_ptr<Running>& r) {
    const auto& job = r->job;
    const Topics::Target target{job.bus, job.drive};
    const auto end = [this] {
        running_.reset();
        start_command();
    };
    const auto drive = r->drive.lock();
    if (!drive) {
        end();  // the bridge is going
        return;
    }
    if (r->next == r->actions.size()) {
        if (!r->renewed) {
            // A write to a register outside the lease's own does not renew it: the command's
            // arrival does. NotPermitted when the bridge holds no lease on the drive: nothing to
            // renew, no error.
            drive->drive.async_keep_alive([](const std::expected<void, Error>&) {});
        }
        if (log::enabled(log::Level::Debug)) {
            log::debug("command " + r->command.id.dump() + " to " + job.bus + "/" + job.drive + ": done",
                       {.bus = job.bus, .drive = job.drive});
        }
        link_->publish(topics_.result(job.bus, job.drive), result_ok(r->command.id).dump(), 1, false);
        end();
        return;
    }
    // Checked before each action: a command that has run out of time acts no further.
    const auto left =
        time_left(r->command.freshness, job.received, Clock::now() - job.arrived, config_.limits.max_command_age);
    if (!left) {
        refuse(target, r->command.id, left.error().reason, with_done(left.error().message, r->done_so_far));
        end();
        return;
    }
    const Action& a = r->actions[r->next];
    auto after = [this, r, a](const std::expected<void, Error>& done) {
        const auto& on = r->job;
        if (!done) {
            if (log::enabled(log::Level::Debug)) {
                log::debug(
                    "command " + r->command.id.dump() + " to " + on.bus + "/" + on.drive + ": " + done.error().message,
                    {.bus = on.bus, .drive = on.drive});
            }
            const std::string what = a.kind == Action::Kind::Write ? "write " + a.name + ": " : std::string();
            link_->publish(topics_.result(on.bus, on.drive),
                           result_error(r->command.id, reason_of(done.error().kind),
                                        with_done(what + done.error().message, r->done_so_far))
                               .dump(),
                           1, false);
            running_.reset();
            start_command();
            return;
        }
        r->done_so_far +=
            (r->done_so_far.empty() ? "" : ", ") +
            (a.kind == Action::Kind::Write ? "write " + a.name
                                           : std::string(a.kind == Action::Kind::KeepAlive ? "heartbeat" : "release"));
        ++r->next;
        step(r);
    };
    switch (a.kind) {
    case Action::Kind::Write: {
        const std::array<std::uint16_t, 1> word{a.raw};
        // The command's time left bounds the write too: held up in drivebusd's queue (a slow
        // or late drive ahead of it) past that, drivebusd drops it rather than send it late.
        drive->drive.async_write(a.address, word, std::move(after), write_options(*left));
        break;
    }
    case Action::Kind::KeepAlive:
        r->renewed = true;
        drive->drive.async_keep_alive(std::move(after));
        break;
    case Action::Kind::Release:
        r->renewed = true;
        drive->drive.async_release_control(std::move(after));
        break;
    }
}

}  // namespace drivebus::mqtt
