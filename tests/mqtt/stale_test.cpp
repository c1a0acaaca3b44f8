// SPDX-License-Identifier: Apache-2.0
// Stale commands end to end: a retained command (the broker hands it to every new subscription)
// is refused saying so, and one whose time runs out while its write waits in drivebusd's queue
// is dropped there; the simulated drive receives no command word and no reference for them (its
// write log). A command past its not_after or older than the bridge's limit is refused before
// it acts: tests/mqtt/relay_test.cpp, on a virtual clock. One RouDi per machine: RESOURCE_LOCK
// iceoryx.
#include <gtest/gtest.h>

#include <chrono>
#include <future>

#include "bridge_fixture.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// The simulator's log of the pump's writes holds FA00 (command word) or FA01 (reference).
bool pump_commanded(Stack& stack) {
    const auto writes = stack.sim().command("writes 1");
    return writes.find("0xFA00=") != std::string::npos || writes.find("0xFA01=") != std::string::npos;
}

TEST_F(MqttBridge, ARetainedRunIsRefusedOnEveryConnectionAndNeverActs) {
    // Published with the retain flag before the bridge runs: the broker hands it to each of the
    // bridge's subscriptions.
    const std::string set = drive_topic("pump", "set");
    ASSERT_EQ(mosquitto_pub(broker_.port(), set, R"({"id": "old-run", "frequency": 20, "verb": "run"})", true).first,
              0);
    start_bridge();
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    const auto first = result("pump", "old-run", 20s);
    ASSERT_TRUE(first) << bridge_output();
    EXPECT_EQ((*first)["reason"], "retained") << first->dump();
    // Once the bridge knows the pump for sure, its session is taken over (another client with its
    // id): it reconnects, subscribes again and gets the retained command again.
    const std::size_t from = watcher_.count();
    const auto [status, out] = run_program({MOSQUITTO_PUB_PATH, "-h", "127.0.0.1", "-p", std::to_string(broker_.port()),
                                            "-i", "drivebus-mqtt-" + node_, "-t", "drivebus-test/kick", "-m", "x"});
    ASSERT_EQ(status, 0) << out;
    const auto again = watcher_.wait(
        drive_topic("pump", "result"), [](const Message& m) { return parsed(m).value("id", Json()) == "old-run"; }, 20s,
        from);
    ASSERT_TRUE(again) << "the retained command did not come again after the bridge reconnected\n" << bridge_output();
    const auto r = parsed(*again);
    EXPECT_EQ(r["ok"], false) << r.dump();
    EXPECT_EQ(r["reason"], "retained") << r.dump();
    EXPECT_NE(r.value("error", "").find("retain"), std::string::npos) << r.dump();
    EXPECT_FALSE(pump_commanded(stack_)) << stack_.sim().command("writes 1");
    EXPECT_NE(stack_.sim_register(1, "FA00"), kRunForward);
}

TEST_F(MqttBridge, ACommandWhoseTimeRunsOutInDrivebusdsQueueIsDroppedThereAndNeverSentLate) {
    start_bridge();
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    // The fan turns late (past the response time-out, within the guard): a write to it holds the
    // line through every attempt, 4 x (100 ms time-out + 100 ms guard).
    const auto fan_word = [&] { return occurrences(stack_.sim().command("writes 2"), "0x0191=400"); };
    const std::size_t fan_before = fan_word();
    ASSERT_EQ(stack_.sim().command("fault 2 late=130ms").rfind("ok", 0), 0U);
    auto fan = std::async(std::launch::async, [&] {
        return run_program({DRIVEBUSCTL_PATH, "--bus", stack_.bus(), "write", "fan", "W401", "400"});
    });
    ASSERT_TRUE(wait_until([&] { return fan_word() > fan_before; }, 10s)) << stack_.daemon_output();
    // Sent now, the pump's run waits behind the fan for longer than its 300 ms.
    const Json run{{"id", "behind"}, {"verb", "run"}, {"max_age", "300ms"}};
    ASSERT_TRUE(watcher_.publish(drive_topic("pump", "set"), run.dump()));
    const auto r = result("pump", "behind", 20s);
    ASSERT_TRUE(r) << bridge_output();
    EXPECT_EQ((*r)["ok"], false) << r->dump();
    EXPECT_EQ((*r)["reason"], "expired") << r->dump();
    // drivebusd's drop (libdrivebus's words), not the bridge's own check before the write.
    EXPECT_NE(r->value("error", "").find("not on the wire by its deadline"), std::string::npos) << r->dump();
    const auto [fan_status, fan_out] = fan.get();
    EXPECT_NE(fan_status, 0) << fan_out;  // the late fan never answered in time
    ASSERT_EQ(stack_.sim().command("clear 2").rfind("ok", 0), 0U);
    // The line is free again: a write still queued would go before the pump's next polls.
    const auto requests = stack_.sim_requests();
    ASSERT_TRUE(wait_until([&] { return stack_.sim_requests() >= requests + 3; }, 10s));
    EXPECT_FALSE(pump_commanded(stack_)) << stack_.sim().command("writes 1");
    EXPECT_NE(stack_.sim_register(1, "FA00"), kRunForward);
}

}  // namespace
}  // namespace drivebus::test
