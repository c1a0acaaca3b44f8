// SPDX-License-Identifier: Apache-2.0
// How late a command may act: its not_after, max_age and sent_at, and the bridge's own limit,
// on made-up times (mqtt/freshness.hpp).
#include <gtest/gtest.h>

#include "mqtt/command.hpp"
#include "mqtt/config.hpp"
#include "mqtt/freshness.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

// 2026-12-03T14:05:00Z
const WallTime kNoon =
    WallTime(std::chrono::sys_days(std::chrono::year(2026) / 12 / 3).time_since_epoch()) + 14h + 5min;

Freshness of(std::string_view payload) {
    const auto c = parse_command(payload, 4096);
    EXPECT_TRUE(c) << c.error().message;
    return c ? c->freshness : Freshness{};
}

TEST(MqttFreshness, TimesAreUnixMillisecondsOrRfc3339WithAnOffset) {
    EXPECT_EQ(parse_time("2026-12-03T14:05:00Z").value(), kNoon);
    EXPECT_EQ(parse_time("2026-12-03t15:05:00.250+01:00").value(), kNoon + 250ms);
    EXPECT_EQ(parse_time("2026-12-03T09:35:00.5-04:30").value(), kNoon + 500ms);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(kNoon.time_since_epoch()).count();
    EXPECT_EQ(parse_time(ms + 7).value(), kNoon + 7ms);
    for (const Json& bad : {Json("2026-12-03T14:05:00"), Json("2026-12-03 14:05:00Z"), Json("2026-02-30T14:05:00Z"),
                            Json("2026-12-03T24:05:00Z"), Json("2026-12-03T14:05:00.Z"), Json("yesterday"),
                            Json(1796306700),  // seconds, not milliseconds
                            Json(1.5), Json(true)}) {
        EXPECT_FALSE(parse_time(bad)) << bad.dump();
    }
}

TEST(MqttFreshness, CommandsCarryTheirLimits) {
    const auto f = of(R"({"id": 1, "verb": "run", "not_after": "2026-12-03T14:05:02Z", "max_age": "1500ms",
                          "sent_at": 1796306700000})");
    EXPECT_EQ(f.not_after, kNoon + 2s);
    EXPECT_EQ(f.max_age, 1500ms);
    EXPECT_EQ(f.sent_at, kNoon);
    for (const auto* bad :
         {R"({"id": 1, "verb": "run", "max_age": 2})", R"({"id": 1, "verb": "run", "max_age": "0s"})",
          R"({"id": 1, "verb": "run", "max_age": "25h"})", R"({"id": 1, "verb": "run", "not_after": "soon"})"}) {
        const auto c = parse_command(bad, 4096);
        ASSERT_FALSE(c) << bad;
        EXPECT_EQ(c.error().id, 1) << "the refusal keeps the id: " << bad;
    }
}

TEST(MqttFreshness, TheBridgesLimitCountsTheWaitWhenTheAgeIsUnknown) {
    const Freshness none;
    EXPECT_EQ(time_left(none, kNoon, 0ms, 10s).value(), 10s);
    EXPECT_EQ(time_left(none, kNoon, 9999ms, 10s).value(), 1ms);
    const auto late = time_left(none, kNoon, 10s, 10s);
    ASSERT_FALSE(late);
    EXPECT_EQ(late.error().reason, "expired");
    EXPECT_NE(late.error().message.find("max_command_age"), std::string::npos) << late.error().message;
    // No limit at all: nothing to say.
    EXPECT_EQ(time_left(none, kNoon, 1h, 0ms).value(), std::nullopt);
}

TEST(MqttFreshness, SentAtAddsTheTimeBeforeArrival) {
    Freshness f{.not_after = {}, .max_age = {}, .sent_at = kNoon};
    EXPECT_EQ(time_left(f, kNoon + 3s, 1s, 10s).value(), 6s);
    EXPECT_EQ(time_left(f, kNoon + 9s, 999ms, 10s).value(), 1ms);
    EXPECT_EQ(time_left(f, kNoon + 9s, 1s, 10s).error().reason, "expired");
    // A day-old command delivered late (QoS 1 kept by the broker, or queued by the sender).
    EXPECT_EQ(time_left(f, kNoon + 24h, 0ms, 10s).error().reason, "expired");
    // A sender's clock a little ahead: age 0, not negative.
    EXPECT_EQ(time_left(f, kNoon - 2s, 0ms, 10s).value(), 10s);
    // Far ahead (more than the limit): the clocks disagree, the age cannot be trusted.
    const auto skew = time_left(f, kNoon - 11s, 0ms, 10s);
    ASSERT_FALSE(skew);
    EXPECT_EQ(skew.error().reason, "clock_skew");
}

TEST(MqttFreshness, MaxAgeShortensTheBridgesLimitButNeverLengthensIt) {
    Freshness shorter{.not_after = {}, .max_age = 2s, .sent_at = kNoon};
    EXPECT_EQ(time_left(shorter, kNoon + 1s, 0ms, 10s).value(), 1s);
    const auto late = time_left(shorter, kNoon + 1s, 1s, 10s);
    ASSERT_FALSE(late);
    EXPECT_NE(late.error().message.find("its max_age"), std::string::npos) << late.error().message;
    Freshness longer{.not_after = {}, .max_age = 1min, .sent_at = kNoon};
    EXPECT_EQ(time_left(longer, kNoon + 11s, 0ms, 10s).error().reason, "expired");
    // A bridge without a limit takes the command's.
    EXPECT_EQ(time_left(longer, kNoon + 11s, 0ms, 0ms).value(), 49s);
}

TEST(MqttFreshness, NotAfterIsAnAbsoluteEnd) {
    Freshness f{.not_after = kNoon + 5s, .max_age = {}, .sent_at = {}};
    EXPECT_EQ(time_left(f, kNoon, 1s, 0ms).value(), 4s);
    EXPECT_EQ(time_left(f, kNoon, 1s, 2s).value(), 1s);  // the nearer end wins
    EXPECT_EQ(time_left(f, kNoon + 4s, 1s, 0ms).error().reason, "expired");
    const auto past = time_left(f, kNoon + 6s, 0ms, 10s);
    ASSERT_FALSE(past);
    EXPECT_NE(past.error().message.find("not_after"), std::string::npos) << past.error().message;
}

TEST(MqttFreshness, TheBridgesLimitIsAConfigKey) {
    const std::string base = "node = \"b\"\n[[bus]]\nname = \"rs485-0\"\n";
    auto c = parse_config(base, "mqtt.toml", "board");
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->limits.max_command_age, 10s);
    c = parse_config(base + "[limits]\nmax_command_age = \"2s\"\n", "mqtt.toml", "board");
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->limits.max_command_age, 2s);
    c = parse_config(base + "[limits]\nmax_command_age = \"10ms\"\n", "mqtt.toml", "board");
    ASSERT_FALSE(c);
    EXPECT_NE(c.error().message.find("max_command_age"), std::string::npos) << c.error().message;
}

}  // namespace
}  // namespace drivebus::mqtt
