// SPDX-License-Identifier: Apache-2.0
#include "rtu/timing.hpp"

#include <gtest/gtest.h>

namespace drivebus::rtu {
namespace {

using std::chrono::microseconds;
using std::chrono::nanoseconds;

TEST(Timing, BitsPerCharacter) {
    EXPECT_EQ(bits_per_character({19200, 8, Parity::None, 1}), 10U);
    EXPECT_EQ(bits_per_character({19200, 8, Parity::Even, 1}), 11U);
    EXPECT_EQ(bits_per_character({19200, 8, Parity::Odd, 1}), 11U);
    EXPECT_EQ(bits_per_character({19200, 8, Parity::None, 2}), 11U);
    EXPECT_EQ(bits_per_character({19200, 8, Parity::Even, 2}), 12U);
    EXPECT_EQ(bits_per_character({9600, 7, Parity::Even, 1}), 10U);
}

TEST(Timing, At9600EightNoneOne) {
    const auto t = character_timing({9600, 8, Parity::None, 1}).value();
    EXPECT_EQ(t.character, nanoseconds(1'041'667));  // 10 / 9600 s
    EXPECT_EQ(t.t1_5, nanoseconds(1'562'500));
    EXPECT_EQ(t.t3_5, nanoseconds(3'645'833));
}

TEST(Timing, At19200EightEvenOne) {
    const auto t = character_timing({19200, 8, Parity::Even, 1}).value();
    EXPECT_EQ(t.character, nanoseconds(572'917));  // 11 / 19200 s
    EXPECT_EQ(t.t1_5, nanoseconds(859'375));
    EXPECT_EQ(t.t3_5, nanoseconds(2'005'208));
}

TEST(Timing, At19200EightNoneTwo) {
    const auto t = character_timing({19200, 8, Parity::None, 2}).value();
    EXPECT_EQ(t.t3_5, nanoseconds(2'005'208));
}

TEST(Timing, FixedSilencesAbove19200) {
    for (const std::uint32_t baud : {38400U, 57600U, 115200U, 230400U}) {
        const auto t = character_timing({baud, 8, Parity::Even, 1}).value();
        EXPECT_EQ(t.t1_5, microseconds(750)) << baud;
        EXPECT_EQ(t.t3_5, microseconds(1750)) << baud;
    }
    const auto t = character_timing({115200, 8, Parity::None, 1}).value();
    EXPECT_EQ(t.character, nanoseconds(86'806));
}

TEST(Timing, WireTime) {
    const auto t = character_timing({9600, 8, Parity::None, 1}).value();
    EXPECT_EQ(wire_time(t, 8), t.character * 8);
    EXPECT_EQ(wire_time(t, 0), nanoseconds(0));
}

TEST(Timing, InvalidFormats) {
    EXPECT_EQ(character_timing({0, 8, Parity::None, 1}).error(), LineFormatError::InvalidBaud);
    EXPECT_EQ(character_timing({5'000'000, 8, Parity::None, 1}).error(), LineFormatError::InvalidBaud);
    EXPECT_EQ(character_timing({9600, 9, Parity::None, 1}).error(), LineFormatError::InvalidDataBits);
    EXPECT_EQ(character_timing({9600, 4, Parity::None, 1}).error(), LineFormatError::InvalidDataBits);
    EXPECT_EQ(character_timing({9600, 8, Parity::None, 0}).error(), LineFormatError::InvalidStopBits);
    EXPECT_EQ(character_timing({9600, 8, Parity::None, 3}).error(), LineFormatError::InvalidStopBits);
    EXPECT_FALSE(to_string(LineFormatError::InvalidBaud).empty());
}

}  // namespace
}  // namespace drivebus::rtu
