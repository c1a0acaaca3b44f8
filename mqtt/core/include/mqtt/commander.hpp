// SPDX-License-Identifier: Apache-2.0
// The bridge's commands, pure: a command message in (its topic's bus and drive, payload, retain
// flag, when it arrived), refused at once or queued, and carried out one at a time, each action
// (a register write, the lease's renewal or release) handed out as a step for drivebusd whose
// answer comes back with its ticket; results out for .../result. No broker, no drivebusd, no
// clock, no log: the relay (mqtt/relay.hpp) carries the steps and results out, tests
// drive it on a virtual clock (tests/mqtt/commander_test.cpp).
//
// The rules (docs/mqtt.md, "Commands"):
// - refused at once, each with its reason: larger than max_payload ("too_large"), not JSON or
//   not a command ("malformed"), retained ("retained": a broker hands it to every new
//   subscription, so every reconnection would carry it out again), a bus this bridge has not
//   ("unknown_bus"), a drive its bus has not or not yet ("unknown_drive"), commands not enabled
//   for the drive ("commands_disabled"), command_queue commands already waiting ("busy");
// - carried out in the order they came, one at a time; a command the drive's profile cannot
//   carry out is refused ("invalid") before any of it acts;
// - before each action its time left is checked (freshness.hpp): a command past its time acts
//   no further ("expired", "clock_skew"), and its result says what it did before (not undone);
//   a write carries the time left as its deadline in drivebusd's queue;
// - an action that fails ends the command: the result gives libdrivebus's error kind as its
//   reason ("not_permitted", "timeout", ...) and what was done before;
// - the lease is renewed by the command's writes, its heartbeat, or the keep-alive added after a
//   command that has neither; nothing else renews it, so a commander that goes lets it run out.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <expected>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "drivebus/client.hpp"
#include "mqtt/command.hpp"
#include "mqtt/freshness.hpp"
#include "mqtt/topics.hpp"

namespace drivebus::mqtt {

// What the commander reads of the buses: which it has, and the drives each has now.
class Roster {
public:
    Roster() = default;
    virtual ~Roster() = default;
    Roster(const Roster&) = delete;
    Roster& operator=(const Roster&) = delete;
    Roster(Roster&&) = delete;
    Roster& operator=(Roster&&) = delete;

    struct Drive {
        bool commands = false;             // enabled in its [[bus.drive]]
        const Profile* profile = nullptr;  // null: registers by number, raw values only
    };
    [[nodiscard]] virtual bool has_bus(std::string_view bus) const = 0;
    // Nothing when the bus has no such drive, or drivebusd has not been reached yet.
    [[nodiscard]] virtual std::optional<Drive> drive(std::string_view bus, std::string_view drive) const = 0;
};

struct CommanderLimits {
    std::size_t max_payload = 4096;
    std::size_t command_queue = 32;
    std::chrono::nanoseconds max_command_age = std::chrono::seconds(10);  // zero: no limit of the bridge's
};

// One action for drivebusd; its answer comes back through Commander::done with its ticket
// (ticket 0: no answer is awaited).
struct Step {
    std::uint64_t ticket = 0;
    std::string bus;
    std::string drive;
    Action action;
    std::optional<std::chrono::nanoseconds> deadline;  // a write's: the command's time left
};

// A result to publish on the drive's .../result topic (QoS 1, not retained).
struct CommandResult {
    std::string bus;
    std::string drive;
    Json payload;
};

// A line for the debug log, about one command to one drive.
struct CommandNote {
    std::string bus;
    std::string drive;
    std::string text;
};

struct CommanderEffects {
    std::vector<CommandResult> results;
    std::vector<Step> steps;
    std::vector<CommandNote> debug;
};

struct CommanderCounters {
    std::uint64_t commands = 0;          // taken to be carried out
    std::uint64_t commands_refused = 0;  // every result that is not ok
    std::uint64_t commands_queue_full = 0;
};

class Commander {
public:
    using Time = std::chrono::steady_clock::time_point;

    Commander(CommanderLimits limits, const Roster& roster);

    // A message on a set topic: `received` is the wall clock when it arrived (its sent_at is
    // compared with it), `arrived` the same moment on the steady clock (its wait counts from it).
    CommanderEffects message(const Topics::Target& target, std::string_view payload, bool retained, WallTime received,
                             Time arrived);
    // drivebusd's answer to the step with this ticket.
    CommanderEffects done(std::uint64_t ticket, const std::expected<void, Error>& result, Time now);

    [[nodiscard]] std::size_t waiting() const noexcept { return queue_.size(); }
    [[nodiscard]] bool running() const noexcept { return running_.has_value(); }
    [[nodiscard]] const CommanderCounters& counters() const noexcept { return counters_; }

private:
    struct Job {
        Topics::Target target;
        Command command;
        WallTime received;
        Time arrived;
    };
    struct Running {
        Job job;
        std::vector<Action> actions;
        std::size_t next = 0;
        bool renewed = false;
        std::string done_so_far;
        std::uint64_t ticket = 0;  // the step under way
    };

    void refuse(const Topics::Target& target, const Json& id, std::string_view reason, std::string_view message,
                CommanderEffects& out);
    // The next queued command, while none is under way.
    void start(Time now, CommanderEffects& out);
    // The running command's next action, or its end with its result.
    void step(Time now, CommanderEffects& out);

    CommanderLimits limits_;
    const Roster& roster_;
    std::deque<Job> queue_;
    std::optional<Running> running_;
    std::uint64_t next_ticket_ = 1;
    CommanderCounters counters_;
};

}  // namespace drivebus::mqtt
