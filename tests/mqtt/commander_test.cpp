// SPDX-License-Identifier: Apache-2.0
// The bridge's Commander on a virtual clock: no broker, no drivebusd. The timing cases an
// end-to-end test reaches only by luck (a command whose time runs out between two of its
// actions, a write refused because another client's lease holds as it arrives, answers that come
// late or twice) are each a step here.
#include <gtest/gtest.h>

#include <map>

#include "mqtt/commander.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;
using Time = Commander::Time;

Profile atv21() {
    auto p = load_profile(std::string(DRIVEBUS_TEST_PROFILE_DIR) + "/atv21.toml");
    EXPECT_TRUE(p) << p.error().message;
    return *p;
}

// Bus line1: "pump" (an ATV21, commands enabled) and "fan" (commands not enabled).
class Fleet final : public Roster {
public:
    Fleet() : profile_(atv21()) {}
    [[nodiscard]] bool has_bus(std::string_view bus) const override { return bus == "line1"; }
    [[nodiscard]] std::optional<Drive> drive(std::string_view bus, std::string_view drive) const override {
        if (bus != "line1" || (drive != "pump" && drive != "fan") || (drive == "pump" && pump_gone)) {
            return std::nullopt;
        }
        return Drive{.commands = drive == "pump", .profile = &profile_};
    }
    bool pump_gone = false;

private:
    Profile profile_;
};

const Topics::Target kPump{"line1", "pump"};
const WallTime kWall = WallTime(std::chrono::seconds(1'796'000'000));  // 2026-11-29
const Time kT0 = Time(std::chrono::hours(100));

CommanderLimits limits() {
    return CommanderLimits{.max_payload = 4096, .command_queue = 2, .max_command_age = 10s};
}

Error error(ErrorKind kind, std::string message) {
    Error e;
    e.kind = kind;
    e.message = std::move(message);
    return e;
}

std::string reason(const CommandResult& r) {
    return r.payload.contains("reason") ? r.payload["reason"].get<std::string>() : std::string("(ok)");
}

}  // namespace

TEST(Commander, ARunIsCarriedOutOneActionAtATimeAndItsResultComesLast) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    auto e = c.message(kPump, R"({"id": 1, "frequency": 40, "verb": "run"})", false, kWall, kT0);
    EXPECT_TRUE(e.results.empty());
    ASSERT_EQ(e.steps.size(), 1U);
    EXPECT_EQ(e.steps[0].action.address, 0xFA01);
    EXPECT_EQ(e.steps[0].action.raw, 4000);
    EXPECT_EQ(e.steps[0].deadline, std::chrono::nanoseconds(10s));  // the bridge's max_command_age
    EXPECT_NE(e.steps[0].ticket, 0U);

    e = c.done(e.steps[0].ticket, {}, kT0 + 100ms);
    ASSERT_EQ(e.steps.size(), 1U);
    EXPECT_EQ(e.steps[0].action.address, 0xFA00);
    EXPECT_EQ(e.steps[0].deadline, std::chrono::nanoseconds(9900ms));  // the time left
    EXPECT_TRUE(e.results.empty());

    e = c.done(e.steps[0].ticket, {}, kT0 + 200ms);
    ASSERT_EQ(e.results.size(), 1U);
    EXPECT_EQ(e.results[0].payload, result_ok(1));
    EXPECT_EQ(e.results[0].drive, "pump");
    // Its writes were not to the lease's own register: the command renews the lease after them,
    // and waits for no answer to that.
    ASSERT_EQ(e.steps.size(), 1U);
    EXPECT_EQ(e.steps[0].action.kind, Action::Kind::KeepAlive);
    EXPECT_EQ(e.steps[0].ticket, 0U);
    EXPECT_FALSE(c.running());
    EXPECT_EQ(c.counters().commands, 1U);
}

TEST(Commander, AHeartbeatRenewsTheLeaseItselfAndNothingIsAddedAfterIt) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    auto e = c.message(kPump, R"({"id": "hb", "verb": "heartbeat"})", false, kWall, kT0);
    ASSERT_EQ(e.steps.size(), 1U);
    EXPECT_EQ(e.steps[0].action.kind, Action::Kind::KeepAlive);
    EXPECT_FALSE(e.steps[0].deadline);
    e = c.done(e.steps[0].ticket, {}, kT0 + 1ms);
    ASSERT_EQ(e.results.size(), 1U);
    EXPECT_EQ(e.results[0].payload, result_ok("hb"));
    EXPECT_TRUE(e.steps.empty());
}

TEST(Commander, CommandsTakeTurnsInTheOrderTheyCameAndTheQueueIsBounded) {
    const Fleet fleet;
    Commander c(limits(), fleet);  // 2 may wait
    auto first = c.message(kPump, R"({"id": 1, "verb": "stop"})", false, kWall, kT0);
    ASSERT_EQ(first.steps.size(), 1U);
    EXPECT_TRUE(c.message(kPump, R"({"id": 2, "verb": "heartbeat"})", false, kWall, kT0).steps.empty());
    EXPECT_TRUE(c.message(kPump, R"({"id": 3, "verb": "heartbeat"})", false, kWall, kT0).steps.empty());
    EXPECT_EQ(c.waiting(), 2U);
    const auto full = c.message(kPump, R"({"id": 4, "verb": "heartbeat"})", false, kWall, kT0);
    ASSERT_EQ(full.results.size(), 1U);
    EXPECT_EQ(reason(full.results[0]), "busy");
    EXPECT_EQ(full.results[0].payload["id"], 4);
    EXPECT_EQ(c.counters().commands_queue_full, 1U);

    auto e = c.done(first.steps[0].ticket, {}, kT0 + 1ms);
    // The first's result and keep-alive, then the second's heartbeat.
    ASSERT_EQ(e.results.size(), 1U);
    EXPECT_EQ(e.results[0].payload, result_ok(1));
    ASSERT_EQ(e.steps.size(), 2U);
    EXPECT_EQ(e.steps[0].ticket, 0U);
    EXPECT_NE(e.steps[1].ticket, 0U);
    e = c.done(e.steps[1].ticket, {}, kT0 + 2ms);
    ASSERT_EQ(e.results.size(), 1U);
    EXPECT_EQ(e.results[0].payload, result_ok(2));
    EXPECT_EQ(c.waiting(), 0U);
    EXPECT_TRUE(c.running());
}

TEST(Commander, ACommandWhoseTimeRunsOutBetweenTwoActionsActsNoFurtherAndSaysWhatItDid) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    auto e = c.message(kPump, R"({"id": 7, "frequency": 40, "verb": "run", "max_age": "2s"})", false, kWall, kT0);
    ASSERT_EQ(e.steps.size(), 1U);
    EXPECT_EQ(e.steps[0].deadline, std::chrono::nanoseconds(2s));  // its own max_age, shorter than the bridge's
    // The drive was slow: its first write was answered after the command's time.
    e = c.done(e.steps[0].ticket, {}, kT0 + 2500ms);
    EXPECT_TRUE(e.steps.empty());  // no run
    ASSERT_EQ(e.results.size(), 1U);
    EXPECT_EQ(reason(e.results[0]), "expired");
    EXPECT_NE(e.results[0].payload["error"].get<std::string>().find("write FA01 done before: not undone"),
              std::string::npos)
        << e.results[0].payload.dump();
}

TEST(Commander, ACommandThatWaitedItsTimeBehindOthersNeverActs) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    auto first = c.message(kPump, R"({"id": 1, "verb": "heartbeat"})", false, kWall, kT0);
    (void)c.message(kPump, R"({"id": 2, "verb": "run", "max_age": "1s"})", false, kWall, kT0 + 10ms);
    const auto e = c.done(first.steps[0].ticket, {}, kT0 + 1500ms);
    ASSERT_EQ(e.results.size(), 2U);
    EXPECT_EQ(e.results[1].payload["id"], 2);
    EXPECT_EQ(reason(e.results[1]), "expired");
    EXPECT_TRUE(e.steps.empty());
}

TEST(Commander, AWriteRefusedAsTheLeaseChangesHandsEndsTheCommandWithItsReason) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    auto e = c.message(kPump, R"({"id": 9, "frequency": 40, "verb": "run"})", false, kWall, kT0);
    e = c.done(e.steps[0].ticket, {}, kT0 + 10ms);  // FA01 written under the bridge's lease
    ASSERT_EQ(e.steps.size(), 1U);
    (void)c.message(kPump, R"({"id": 10, "verb": "heartbeat"})", false, kWall, kT0 + 20ms);
    // The lease ran out meanwhile and an HMI took it: the run is refused by drivebusd.
    e = c.done(e.steps[0].ticket,
               std::unexpected(error(ErrorKind::NotPermitted, "not permitted: pump-hmi[120] holds the control lease")),
               kT0 + 30ms);
    ASSERT_EQ(e.results.size(), 1U);
    EXPECT_EQ(reason(e.results[0]), "not_permitted");
    const auto text = e.results[0].payload["error"].get<std::string>();
    EXPECT_NE(text.find("write FA00: not permitted: pump-hmi[120]"), std::string::npos) << text;
    EXPECT_NE(text.find("write FA01 done before: not undone"), std::string::npos) << text;
    // The next command goes on.
    ASSERT_EQ(e.steps.size(), 1U);
    EXPECT_EQ(e.steps[0].action.kind, Action::Kind::KeepAlive);
    EXPECT_NE(e.steps[0].ticket, 0U);
}

TEST(Commander, WhatNeedsNoDrivebusdIsRefusedAtOnceEachWithItsReason) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    const auto refused = [&](const Topics::Target& to, std::string_view payload, bool retained = false) {
        const auto e = c.message(to, payload, retained, kWall, kT0);
        EXPECT_TRUE(e.steps.empty()) << payload;
        EXPECT_EQ(e.results.size(), 1U) << payload;
        return e.results.empty() ? std::string() : reason(e.results[0]);
    };
    EXPECT_EQ(refused(kPump, std::string(5000, ' ')), "too_large");
    EXPECT_EQ(refused(kPump, "run!"), "malformed");
    EXPECT_EQ(refused(kPump, R"({"id": 1, "verb": "run"})", true), "retained");
    EXPECT_EQ(refused({"line9", "pump"}, R"({"id": 1, "verb": "run"})"), "unknown_bus");
    EXPECT_EQ(refused({"line1", "mixer"}, R"({"id": 1, "verb": "run"})"), "unknown_drive");
    EXPECT_EQ(refused({"line1", "fan"}, R"({"id": 1, "verb": "run"})"), "commands_disabled");
    EXPECT_EQ(refused(kPump, R"({"id": 1, "registers": {"FD00": 1}})"), "invalid");  // read-only
    EXPECT_EQ(c.counters().commands_refused, 7U);
    EXPECT_FALSE(c.running());
}

TEST(Commander, AnAnswerNotAwaitedChangesNothing) {
    const Fleet fleet;
    Commander c(limits(), fleet);
    auto e = c.message(kPump, R"({"id": 1, "verb": "stop"})", false, kWall, kT0);
    const auto ticket = e.steps[0].ticket;
    EXPECT_TRUE(c.done(0, {}, kT0).steps.empty());             // the keep-alive's
    EXPECT_TRUE(c.done(ticket + 1, {}, kT0).results.empty());  // no such step
    e = c.done(ticket, {}, kT0 + 1ms);
    ASSERT_EQ(e.results.size(), 1U);
    const auto again = c.done(ticket, {}, kT0 + 2ms);  // twice
    EXPECT_TRUE(again.results.empty());
    EXPECT_TRUE(again.steps.empty());
}

TEST(Commander, ADriveGoneBeforeItsTurnGetsItsCommandRefused) {
    Fleet fleet;
    Commander c(limits(), fleet);
    auto first = c.message(kPump, R"({"id": 1, "verb": "heartbeat"})", false, kWall, kT0);
    (void)c.message(kPump, R"({"id": 2, "verb": "stop"})", false, kWall, kT0);
    fleet.pump_gone = true;
    const auto e = c.done(first.steps[0].ticket, {}, kT0 + 1ms);
    ASSERT_EQ(e.results.size(), 2U);
    EXPECT_EQ(reason(e.results[1]), "unknown_drive");
    EXPECT_TRUE(e.steps.empty());
}

}  // namespace drivebus::mqtt
