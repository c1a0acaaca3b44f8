// SPDX-License-Identifier: Apache-2.0
#include "mqtt/commander.hpp"

#include <algorithm>
#include <utility>

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

std::string what_of(const Action& a) {
    switch (a.kind) {
    case Action::Kind::Write: return "write " + a.name;
    case Action::Kind::KeepAlive: return "heartbeat";
    case Action::Kind::Release: break;
    }
    return "release";
}

}  // namespace

Commander::Commander(CommanderLimits limits, const Roster& roster) : limits_(limits), roster_(roster) {}

void Commander::refuse(const Topics::Target& target, const Json& id, std::string_view reason, std::string_view message,
                       CommanderEffects& out) {
    ++counters_.commands_refused;
    out.debug.push_back({target.bus, target.drive,
                         "command " + id.dump() + " to " + target.bus + "/" + target.drive +
                             " refused: " + std::string(reason) + ": " + std::string(message)});
    out.results.push_back({target.bus, target.drive, result_error(id, reason, message)});
}

CommanderEffects Commander::message(const Topics::Target& target, std::string_view payload, bool retained,
                                    WallTime received, Time arrived) {
    CommanderEffects out;
    if (payload.size() > limits_.max_payload) {
        refuse(target, nullptr, "too_large",
               "payload of " + std::to_string(payload.size()) + " bytes is larger than the limit of " +
                   std::to_string(limits_.max_payload),
               out);
        return out;
    }
    auto parsed = parse_command(payload, limits_.max_payload);
    if (!parsed) {
        refuse(target, parsed.error().id, "malformed", parsed.error().message, out);
        return out;
    }
    // The broker hands a retained command to every new subscription, however old: the bridge's
    // every reconnection would carry it out again.
    if (retained) {
        refuse(target, parsed->id, "retained",
               "a retained command is never carried out: publish commands without the retain flag, and clear "
               "this one (an empty retained message on the same topic)",
               out);
        return out;
    }
    if (!roster_.has_bus(target.bus)) {
        refuse(target, parsed->id, "unknown_bus", "this bridge has no bus '" + target.bus + "'", out);
        return out;
    }
    const auto drive = roster_.drive(target.bus, target.drive);
    if (!drive) {
        refuse(target, parsed->id, "unknown_drive",
               "bus '" + target.bus + "' has no drive '" + target.drive + "' (or drivebusd is not reachable)", out);
        return out;
    }
    if (!drive->commands) {
        refuse(target, parsed->id, "commands_disabled",
               "commands are not enabled for drive '" + target.drive + "' (commands = true in its [[bus.drive]])", out);
        return out;
    }
    if (queue_.size() >= limits_.command_queue) {
        ++counters_.commands_queue_full;
        refuse(target, parsed->id, "busy",
               std::to_string(limits_.command_queue) + " commands already wait: try again later", out);
        return out;
    }
    queue_.push_back(Job{target, std::move(*parsed), received, arrived});
    start(arrived, out);
    return out;
}

void Commander::start(Time now, CommanderEffects& out) {
    while (!running_ && !queue_.empty()) {
        Job job = std::move(queue_.front());
        queue_.pop_front();
        ++counters_.commands;
        const auto drive = roster_.drive(job.target.bus, job.target.drive);
        if (!drive) {
            refuse(job.target, job.command.id, "unknown_drive",
                   "bus '" + job.target.bus + "' has no drive '" + job.target.drive + "' any more", out);
            continue;
        }
        auto actions = plan(job.command, drive->profile);
        if (!actions) {
            refuse(job.target, job.command.id, "invalid", actions.error(), out);
            continue;
        }
        running_.emplace(Running{.job = std::move(job),
                                 .actions = std::move(*actions),
                                 .next = 0,
                                 .renewed = false,
                                 .done_so_far = {},
                                 .ticket = 0});
        step(now, out);
    }
}

// The lease is renewed here and nowhere else: by the writes a command makes, by its heartbeat,
// and by the keep-alive each other command adds. No timer renews it, so a commander that goes
// away lets it run out, and drivebusd applies the drive's fallback.
void Commander::step(Time now, CommanderEffects& out) {
    Running& r = *running_;
    const auto& target = r.job.target;
    if (r.next == r.actions.size()) {
        if (!r.renewed) {
            // A write to a register outside the lease's own does not renew it: the command's
            // arrival does. NotPermitted when the bridge holds no lease on the drive: nothing to
            // renew, no error; so no answer is awaited.
            Action renew;
            renew.kind = Action::Kind::KeepAlive;
            out.steps.push_back({0, target.bus, target.drive, renew, std::nullopt});
        }
        out.debug.push_back(
            {target.bus, target.drive,
             "command " + r.job.command.id.dump() + " to " + target.bus + "/" + target.drive + ": done"});
        out.results.push_back({target.bus, target.drive, result_ok(r.job.command.id)});
        running_.reset();
        return;
    }
    // Checked before each action: a command that has run out of time acts no further.
    const auto left = time_left(r.job.command.freshness, r.job.received, now - r.job.arrived, limits_.max_command_age);
    if (!left) {
        refuse(target, r.job.command.id, left.error().reason, with_done(left.error().message, r.done_so_far), out);
        running_.reset();
        return;
    }
    const Action& a = r.actions[r.next];
    if (a.kind != Action::Kind::Write) {
        r.renewed = true;
    }
    r.ticket = next_ticket_++;
    // The command's time left bounds a write too: held up in drivebusd's queue (a slow or late
    // drive ahead of it) past that, drivebusd drops it rather than send it late.
    out.steps.push_back({r.ticket, target.bus, target.drive, a,
                         a.kind == Action::Kind::Write ? *left : std::optional<std::chrono::nanoseconds>()});
}

CommanderEffects Commander::done(std::uint64_t ticket, const std::expected<void, Error>& result, Time now) {
    CommanderEffects out;
    if (ticket == 0 || !running_ || running_->ticket != ticket) {
        return out;
    }
    Running& r = *running_;
    const Action& a = r.actions[r.next];
    if (!result) {
        const auto& target = r.job.target;
        out.debug.push_back({target.bus, target.drive,
                             "command " + r.job.command.id.dump() + " to " + target.bus + "/" + target.drive + ": " +
                                 result.error().message});
        const std::string what = a.kind == Action::Kind::Write ? "write " + a.name + ": " : std::string();
        ++counters_.commands_refused;
        out.results.push_back({target.bus, target.drive,
                               result_error(r.job.command.id, reason_of(result.error().kind),
                                            with_done(what + result.error().message, r.done_so_far))});
        running_.reset();
    } else {
        r.done_so_far += (r.done_so_far.empty() ? "" : ", ") + what_of(a);
        ++r.next;
        step(now, out);
    }
    start(now, out);
    return out;
}

}  // namespace drivebus::mqtt
