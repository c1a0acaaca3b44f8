// SPDX-License-Identifier: Apache-2.0
// When an open line counts as mute (master/mute_watch.hpp): silence while requests time out,
// for the configured time, then twice as long after each reopen, up to the cap; anything heard
// starts it afresh; silence with nothing sent is no evidence; "off" never says mute.
#include <gtest/gtest.h>

#include "master/mute_watch.hpp"

namespace drivebus::master {
namespace {

using namespace std::chrono_literals;

TEST(MuteWatch, SilenceWhileRequestsTimeOutForTheConfiguredTime) {
    MuteWatch w(10s, 35s);
    const rtu::Instant t0{};
    BusCounters c;
    c.replies = 5;
    w.opened(c, t0);
    EXPECT_EQ(w.next_check(), t0 + 10s);
    c.timeouts = 3;
    EXPECT_FALSE(w.mute(c, t0 + 9s));
    EXPECT_TRUE(w.mute(c, t0 + 10s));
    EXPECT_EQ(w.silent_for(), 10s);
    EXPECT_FALSE(w.next_check().has_value()) << "closed until opened again";
    EXPECT_FALSE(w.mute(c, t0 + 11s));
    // Still mute after the reopen: twice as long, then capped.
    w.opened(c, t0 + 10s);
    c.timeouts = 4;
    EXPECT_FALSE(w.mute(c, t0 + 29s));
    EXPECT_TRUE(w.mute(c, t0 + 30s));
    w.opened(c, t0 + 30s);
    c.timeouts = 5;
    EXPECT_EQ(w.next_check(), t0 + 65s) << "40 s capped at 35 s";
    EXPECT_TRUE(w.mute(c, t0 + 65s));
    // It hears something: the next silence is judged by 10 s again.
    w.opened(c, t0 + 65s);
    c.crc_errors = 1;  // a spoiled frame is still a byte delivered
    EXPECT_FALSE(w.mute(c, t0 + 66s));
    c.timeouts = 9;
    EXPECT_FALSE(w.mute(c, t0 + 75s));
    EXPECT_TRUE(w.mute(c, t0 + 76s));
}

TEST(MuteWatch, SilenceWithNothingSentIsNoEvidence) {
    MuteWatch w(1s, 5s);
    const rtu::Instant t0{};
    BusCounters c;
    w.opened(c, t0);
    EXPECT_FALSE(w.mute(c, t0 + 1h));
    c.timeouts = 1;
    EXPECT_TRUE(w.mute(c, t0 + 1h + 1ms));
}

TEST(MuteWatch, OffNeverSaysMute) {
    MuteWatch w(std::nullopt, 5s);
    const rtu::Instant t0{};
    BusCounters c;
    w.opened(c, t0);
    c.timeouts = 100;
    EXPECT_FALSE(w.mute(c, t0 + 1h));
    EXPECT_FALSE(w.next_check().has_value());
}

}  // namespace
}  // namespace drivebus::master
