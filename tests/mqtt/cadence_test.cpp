// SPDX-License-Identifier: Apache-2.0
// When the bridge publishes a retained state again, on a virtual clock: the first time, a change
// beyond the deadband, the period, a reconnection; and a broker that stalls (publications not
// taken) loses no change.
#include <gtest/gtest.h>

#include "mqtt/cadence.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;
using Time = Cadence::Time;

const Time kT0 = Time(std::chrono::hours(100));  // NOLINT(readability-identifier-naming)

Json state(double hz, std::uint64_t requests = 0) {
    return Json{{"health", "online"},
                {"registers", {{"FD00", {{"raw", static_cast<int>(hz * 100)}, {"value", hz}, {"unit", "Hz"}}}}},
                {"counters", {{"requests", requests}}}};
}

}  // namespace

TEST(Cadence, FirstTimeThenOnAChangeBeyondTheDeadbandOrOnceThePeriodHasPassed) {
    Cadence c(10s, 0.5);
    EXPECT_TRUE(c.due_by_time(kT0));
    EXPECT_TRUE(c.due(state(50.0), kT0, false));
    c.published(state(50.0), kT0);
    EXPECT_FALSE(c.due_by_time(kT0 + 1s));
    EXPECT_FALSE(c.due(state(50.4, 99), kT0 + 1s, false));  // within the deadband; counters never count
    EXPECT_TRUE(c.due(state(50.6), kT0 + 1s, false));
    EXPECT_TRUE(c.due(state(50.0), kT0 + 10s, false));  // the period
    EXPECT_EQ(c.next(), kT0 + 10s);
    Json absent = state(50.0);
    absent["health"] = "absent";
    EXPECT_TRUE(c.due(absent, kT0 + 1s, false));  // anything but a value counts, whatever the deadband
}

TEST(Cadence, ForcedOrMarkedItIsDueWithoutAChange) {
    Cadence c(10s, 0.0);
    c.published(state(50.0), kT0);
    EXPECT_FALSE(c.due(state(50.0), kT0 + 1s, false));
    EXPECT_TRUE(c.due(state(50.0), kT0 + 1s, true));  // the broker connected again
    c.again();                                        // what it says changed in a way the value cannot show
    EXPECT_TRUE(c.due_by_time(kT0 + 1s));
    c.published(state(50.0), kT0 + 1s);
    EXPECT_FALSE(c.due_by_time(kT0 + 2s));
}

TEST(Cadence, APublicationTheBrokerDidNotTakeStaysDueUntilOneIsTaken) {
    Cadence c(10s, 0.5);
    c.published(state(50.0), kT0);
    // A change, and the broker stalls: nothing is recorded as published, so every round after
    // still finds it due, and the first one taken is the newest value.
    EXPECT_TRUE(c.due(state(55.0), kT0 + 1s, false));
    EXPECT_TRUE(c.due(state(55.0), kT0 + 2s, false));
    EXPECT_TRUE(c.due(state(56.0), kT0 + 3s, false));
    c.published(state(56.0), kT0 + 3s);
    EXPECT_FALSE(c.due(state(56.0), kT0 + 4s, false));
    EXPECT_EQ(c.next(), kT0 + 13s);
}

}  // namespace drivebus::mqtt
