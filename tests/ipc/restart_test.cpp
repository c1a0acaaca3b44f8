// SPDX-License-Identifier: Apache-2.0
// drivebusd's own end leaves no drive running without a holder (docs/ipc.md, "Expiry and the
// fallback"): a client holds the pump's lease and runs it; then drivebusd is stopped (SIGTERM,
// as systemctl stop does), killed (SIGKILL, as a crash), or restarted. The lease is long (10 s)
// so that no expiry can be what stops the pump: only drivebusd's own end.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "client_process.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// The simulator's request log items ("FC:0xREG" or "06:0xREG=VALUE").
constexpr std::string_view kStopWord = "06:0xFA00=49152";  // 0xC000, the ATV21's ramp stop
constexpr std::uint16_t kRun = 0xC400;
constexpr std::uint16_t kStop = 0xC000;

StackOptions leased() {
    StackOptions options;
    options.drive_extra = "  lease = \"10s\"\n  fallback = \"stop\"\n";
    return options;
}

// What reached the pump: how many requests in all, and the last ones in order.
struct Received {
    std::uint64_t total = 0;
    std::vector<std::string> items;
};

Received pump_requests(Stack& stack) {
    std::istringstream in(stack.sim().command("requests 1"));
    Received r;
    std::string word;
    in >> word;  // ok
    in >> word;  // total=N
    r.total = std::stoull(word.substr(6));
    while (in >> word) {
        r.items.push_back(word);
    }
    return r;
}

// How many requests reached the pump, once the line is idle: a request the last drivebusd
// wrote just before it was killed may still be in the pty, or in the simulator's framer
// waiting for its silence, and must be counted before the next drivebusd starts, not taken for
// the first request of that one.
std::uint64_t settled_total(Stack& stack) {
    EXPECT_TRUE(wait_until([&] { return stack.sim().command("idle") == "ok idle"; }, 5s))
        << "the simulator's line did not go idle";
    return pump_requests(stack).total;
}

// The requests the pump received after the first `before` of them.
std::vector<std::string> since(const Received& now, std::uint64_t before) {
    const std::uint64_t dropped = now.total - now.items.size();  // older than the log keeps
    EXPECT_GE(before, dropped) << "the simulator's log no longer reaches back that far";
    return {now.items.begin() + static_cast<std::ptrdiff_t>(before - dropped), now.items.end()};
}

std::string record(Stack& stack) {
    std::ifstream in(stack.state_dir() / (stack.bus() + ".leases"));
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// The holder takes the pump's lease and runs it.
void run_pump(Stack& stack, Client& holder) {
    ASSERT_TRUE(holder.printed("holding", 10s)) << holder.output();
    ASSERT_EQ(stack.sim_register(1, "FA00"), kRun);
    ASSERT_TRUE(wait_until([&] { return record(stack).find("lease pump 1 stop") != std::string::npos; }, 5s))
        << record(stack);
}

// systemctl stop: drivebusd writes the stop word before it lets the line go, and exits.
TEST(Restart, AStoppingDrivebusdStopsTheDrivesWhoseLeaseIsHeld) {
    Stack stack(leased());
    Client holder({stack.bus(), "command", "30"});
    run_pump(stack, holder);
    EXPECT_EQ(stack.stop_daemon(), 0) << stack.daemon_output();
    // drivebusd has exited: whatever the pump holds now came from it before that.
    EXPECT_EQ(stack.sim_register(1, "FA00"), kStop) << stack.daemon_output();
    const auto writes = stack.sim().command("writes 1");
    EXPECT_NE(writes.rfind("0xFA00=49152"), std::string::npos) << writes;
    EXPECT_GT(writes.rfind("0xFA00=49152"), writes.rfind("0xFA00=50176")) << writes;
    const auto out = stack.daemon_output();
    const auto said = out.find("drive pump: drivebusd is stopping: the control lease of test_client_command[");
    ASSERT_NE(said, std::string::npos) << out;
    EXPECT_EQ(out.find("ends; fallback: stop", said), out.find(']', said) + 2) << out;
    EXPECT_EQ(record(stack).find("lease "), std::string::npos) << "a clean stop leaves an empty record:\n"
                                                               << record(stack);
}

// A crash: the drivebusd that starts next applies the fallback before anything else reaches
// the pump, publishes the lease as expired, and clears the record.
TEST(Restart, ADrivebusdStartedAfterOneThatWasKilledAppliesTheFallbackFirst) {
    Stack stack(leased());
    Client holder({stack.bus(), "command", "30"});
    run_pump(stack, holder);
    stack.kill_daemon();
    holder.kill9();  // its drivebusd gone, the application ends (libdrivebus cannot reconnect)
    const auto before = settled_total(stack);
    ASSERT_EQ(stack.sim_register(1, "FA00"), kRun) << "nobody stopped the pump";
    stack.start_daemon();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == kStop; }, 10s)) << stack.daemon_output();
    const auto after = since(pump_requests(stack), before);
    ASSERT_FALSE(after.empty());
    EXPECT_EQ(after.front(), kStopWord) << "the first request to reach the pump";
    EXPECT_NE(stack.daemon_output().find("the lease of test_client_command"), std::string::npos)
        << stack.daemon_output();
    EXPECT_NE(stack.daemon_output().find("was held when drivebusd last stopped; applying its fallback: stop"),
              std::string::npos)
        << stack.daemon_output();
    Client lease({stack.bus(), "lease"});
    ASSERT_EQ(lease.wait(10s), 0) << lease.output();
    EXPECT_NE(lease.output().find("lease expired holder kept fallback_ok 1"), std::string::npos) << lease.output();
    EXPECT_TRUE(wait_until([&] { return record(stack).find("lease ") == std::string::npos; }, 5s)) << record(stack);
}

// systemctl stop on a line that has gone quiet: the stop word times out. The record keeps it,
// marked unconfirmed, and the drivebusd that starts next (its opening of the port brings the
// simulated line back) applies it first, and says that it was not confirmed. (Before: the
// failed fallback was dropped, the record left empty, and the pump ran on with no holder.)
TEST(Restart, AFallbackTheDriveDidNotConfirmAtStopIsAppliedByTheNextDrivebusd) {
    Stack stack(leased());
    Client holder({stack.bus(), "command", "30"});
    run_pump(stack, holder);
    ASSERT_EQ(stack.sim().command("mute"), "ok");
    EXPECT_EQ(stack.stop_daemon(), 0) << stack.daemon_output();
    holder.kill9();
    ASSERT_EQ(stack.sim_register(1, "FA00"), kRun) << "the stop word reached the pump on a mute line";
    const auto out = stack.daemon_output();
    EXPECT_NE(out.find("drive pump: the fallback write failed: "), std::string::npos) << out;
    EXPECT_NE(record(stack).find("unconfirmed pump 1 stop test_client_command["), std::string::npos) << record(stack);
    const auto before = settled_total(stack);
    stack.start_daemon();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == kStop; }, 10s)) << stack.daemon_output();
    const auto after = since(pump_requests(stack), before);
    ASSERT_FALSE(after.empty());
    EXPECT_EQ(after.front(), kStopWord) << "the first request to reach the pump";
    EXPECT_NE(stack.daemon_output().find("was not confirmed when drivebusd last stopped; applying it again: stop"),
              std::string::npos)
        << stack.daemon_output();
    EXPECT_TRUE(wait_until([&] { return record(stack).find("pump") == std::string::npos; }, 5s)) << record(stack);
}

// The worst moments for a kill: the instant the run word reaches the pump (its reply perhaps
// still on the wire, the holder not yet answered), without waiting for anything else. The
// record is written before the command goes to the bus, so every time the next drivebusd
// finds the lease and stops the pump first. Six rounds, none missed.
TEST(Restart, KilledTheMomentTheCommandReachesThePumpTheNextDrivebusdStopsIt) {
    Stack stack(leased());
    constexpr int kRounds = 6;
    int stopped = 0;
    for (int round = 0; round < kRounds; ++round) {
        ASSERT_NE(stack.sim_register(1, "FA00"), kRun) << "round " << round;
        Client holder({stack.bus(), "command", "30"});
        ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == kRun; }, 10s))
            << "round " << round << ": " << holder.output();
        stack.kill_daemon();
        holder.kill9();
        const auto before = settled_total(stack);
        stack.start_daemon();
        ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == kStop; }, 10s))
            << "round " << round << ": the pump runs on with no holder\n"
            << stack.daemon_output();
        const auto after = since(pump_requests(stack), before);
        ASSERT_FALSE(after.empty());
        EXPECT_EQ(after.front(), kStopWord) << "round " << round << ": the first request to reach the pump";
        ++stopped;
        ASSERT_TRUE(wait_until([&] { return record(stack).find("pump") == std::string::npos; }, 5s))
            << "round " << round << ": " << record(stack);
    }
    EXPECT_EQ(stopped, kRounds);
}

// systemctl restart (and a package upgrade): stopped, then started. The pump is stopped by the
// one that stops; the one that starts has nothing left to apply.
TEST(Restart, ARestartedDrivebusdLeavesNoDriveRunningWithoutAHolder) {
    Stack stack(leased());
    Client holder({stack.bus(), "command", "30"});
    run_pump(stack, holder);
    EXPECT_EQ(stack.stop_daemon(), 0) << stack.daemon_output();
    holder.kill9();
    EXPECT_EQ(stack.sim_register(1, "FA00"), kStop) << stack.daemon_output();
    const auto before = settled_total(stack);
    stack.start_daemon();
    // The new drivebusd polls the pump, and writes it nothing of its own.
    ASSERT_TRUE(wait_until([&] { return pump_requests(stack).total > before + 20; }, 10s)) << stack.daemon_output();
    EXPECT_EQ(stack.sim_register(1, "FA00"), kStop);
    EXPECT_EQ(stack.daemon_output().find("was held when drivebusd last stopped"), std::string::npos)
        << stack.daemon_output();
    for (const auto& item : since(pump_requests(stack), before)) {
        EXPECT_NE(item.rfind("06:0xFA00", 0), 0U) << item;
    }
}

// A damaged record is read as far as it can be: a clear line, and every drive it names gets its
// fallback; drivebusd runs on.
TEST(Restart, ADamagedRecordIsLoggedAndTheDrivesItNamesGetTheirFallback) {
    Stack stack(leased());
    Client holder({stack.bus(), "command", "30"});
    run_pump(stack, holder);
    stack.kill_daemon();
    holder.kill9();
    std::ofstream(stack.state_dir() / (stack.bus() + ".leases"), std::ios::trunc)
        << "\x01garbage\nlease pump zz ? who\x02\nlease nosuchdrive 9 stop x\n";
    stack.start_daemon();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == kStop; }, 10s)) << stack.daemon_output();
    const auto out = stack.daemon_output();
    EXPECT_NE(out.find("lease record: line 1 is not"), std::string::npos) << out;
    EXPECT_NE(out.find("lease record: line 2 (drive pump) is damaged"), std::string::npos) << out;
    EXPECT_NE(out.find("drive nosuchdrive was held when drivebusd last stopped, and the drive is no longer "
                       "configured"),
              std::string::npos)
        << out;
    EXPECT_NE(out.find("running:"), std::string::npos) << out;
}

}  // namespace
}  // namespace drivebus::test
