// SPDX-License-Identifier: Apache-2.0
// The one duration grammar (lib/duration): what it takes, what it refuses and how it says so.
#include "duration/duration.hpp"

#include <gtest/gtest.h>

namespace drivebus {
namespace {

using namespace std::chrono_literals;

TEST(Duration, ANumberAndAUnit) {
    EXPECT_EQ(parse_duration("1500000ns").value(), 1500us);
    EXPECT_EQ(parse_duration("250us").value(), 250us);
    EXPECT_EQ(parse_duration("100ms").value(), 100ms);
    EXPECT_EQ(parse_duration("2s").value(), 2s);
    EXPECT_EQ(parse_duration("2min").value(), 120s);
    EXPECT_EQ(parse_duration("1.5s").value(), 1500ms);
    EXPECT_EQ(parse_duration("0.25ms").value(), 250us);
    EXPECT_EQ(parse_duration("0ms").value(), 0ns);
    EXPECT_EQ(parse_duration(" 100 ms ").value(), 100ms);
    EXPECT_EQ(parse_duration("1.0000000004s").value(), 1s);  // to the nanosecond
}

TEST(Duration, ABareNumberHasNoUnit) {
    EXPECT_EQ(parse_duration("30").error(), "has no unit: write ns, us, ms, s or min after the number, e.g. '100ms'");
    EXPECT_EQ(parse_duration("1.5").error(), parse_duration("30").error());
}

TEST(Duration, AnythingElseIsNotADuration) {
    for (const char* bad : {"", "ms", "-1ms", "+1ms", "1e3ms", "0x10ms", "1.ms", ".5s", "1.5.2s", "2h", "2 m", "2MS",
                            "fast", "1s1", "1 s s"}) {
        const auto d = parse_duration(bad);
        ASSERT_FALSE(d.has_value()) << bad;
        EXPECT_EQ(d.error().rfind("is not a duration: a number and a unit (ns, us, ms, s or min)", 0), 0U)
            << bad << ": " << d.error();
    }
}

TEST(Duration, TooLarge) {
    EXPECT_EQ(parse_duration("99999999999999999999s").error(), "is too large");
    EXPECT_EQ(parse_duration("9999999999999s").error(), "is too large");
    EXPECT_EQ(parse_duration("9223372036854775808ns").error(), "is too large");
    EXPECT_EQ(parse_duration("9223372036854775807ns").value().count(), 9223372036854775807);
    EXPECT_TRUE(parse_duration("9223372036s").has_value());
}

}  // namespace
}  // namespace drivebus
