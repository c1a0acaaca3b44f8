// SPDX-License-Identifier: Apache-2.0
// libdrivebus's Altivar decoding, against the ATV21 guide's own example values.
#include <gtest/gtest.h>

#include "drivebus/altivar.hpp"

namespace drivebus {
namespace {

void put(shm::DriveSnapshot& s, std::uint16_t address, std::uint16_t value) {
    s.registers.at(s.register_count++) = {address, value, 1, {}, 1};
}

TEST(Altivar, StatusWordFaultAndAlarmsAsTheGuideNamesThem) {
    auto profile = load_profile(std::string(DRIVEBUS_TEST_PROFILE_DIR) + "/atv21.toml");
    ASSERT_TRUE(profile) << profile.error().message;
    shm::DriveSnapshot s{};
    s.sequence = 9;
    // Section 7.5's read block example: FD01 = 0x6404, FD00 = 0x1770, FC91 = 0x0080.
    put(s, 0xFC90, 24);
    put(s, 0xFC91, 0x0080);
    put(s, 0xFD00, 0x1770);
    put(s, 0xFD01, 0x6404);
    const auto st = decode_state(*profile, s);
    EXPECT_EQ(st.sequence, 9U);
    EXPECT_EQ(st.status_word, 0x6404);
    EXPECT_TRUE(st.running);
    EXPECT_TRUE(st.alarm);
    EXPECT_TRUE(st.ready);
    EXPECT_FALSE(st.fault);
    EXPECT_FALSE(st.reverse);
    ASSERT_TRUE(st.output_hz.has_value());
    EXPECT_DOUBLE_EQ(*st.output_hz, 60.0);
    EXPECT_EQ(st.fault_code, 24);
    EXPECT_EQ(st.fault_name, "Err5");
    ASSERT_EQ(st.alarms.size(), 1U);
    EXPECT_EQ(st.alarms[0], "Undercurrent alarm");
    EXPECT_NE(std::find(st.flags.begin(), st.flags.end(), "Run/stop"), st.flags.end());
}

TEST(Altivar, WhatTheSnapshotLacksStaysUnset) {
    auto profile = load_profile(std::string(DRIVEBUS_TEST_PROFILE_DIR) + "/atv21.toml");
    ASSERT_TRUE(profile);
    shm::DriveSnapshot s{};
    s.registers.at(s.register_count++) = {0xFD01, 0x0400, 0, {}, 0};  // never read: not valid
    const auto st = decode_state(*profile, s);
    EXPECT_FALSE(st.status_word.has_value());
    EXPECT_FALSE(st.output_hz.has_value());
    EXPECT_FALSE(st.fault_code.has_value());
    EXPECT_FALSE(st.running);
}

}  // namespace
}  // namespace drivebus
