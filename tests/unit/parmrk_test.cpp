// SPDX-License-Identifier: Apache-2.0
#include "rtu/parmrk.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "hex.hpp"

namespace drivebus::rtu {
namespace {

using test::hex;

std::vector<RxChar> decode(ParmrkDecoder& d, const std::vector<std::uint8_t>& raw) {
    std::vector<RxChar> out(raw.size() + 1);
    out.resize(d.decode(raw, out));
    return out;
}

TEST(Parmrk, PlainBytesPassThrough) {
    ParmrkDecoder d;
    const auto out = decode(d, hex("01 03 00 FE"));
    ASSERT_EQ(out.size(), 4U);
    EXPECT_EQ(out[3], (RxChar{0xFE, false}));
}

TEST(Parmrk, DoubledMarkIsOneDataByte) {
    ParmrkDecoder d;
    const auto out = decode(d, hex("01 FF FF 02"));
    ASSERT_EQ(out.size(), 3U);
    EXPECT_EQ(out[1], (RxChar{0xFF, false}));
    EXPECT_EQ(out[2], (RxChar{0x02, false}));
}

TEST(Parmrk, MarkedCharacterCarriesTheError) {
    ParmrkDecoder d;
    const auto out = decode(d, hex("01 FF 00 41 02"));
    ASSERT_EQ(out.size(), 3U);
    EXPECT_EQ(out[1], (RxChar{0x41, true}));
    EXPECT_EQ(out[2], (RxChar{0x02, false}));
}

TEST(Parmrk, BreakIsAMarkedZero) {
    ParmrkDecoder d;
    const auto out = decode(d, hex("FF 00 00"));
    ASSERT_EQ(out.size(), 1U);
    EXPECT_EQ(out[0], (RxChar{0x00, true}));
}

TEST(Parmrk, SequencesSplitAcrossReads) {
    ParmrkDecoder d;
    EXPECT_TRUE(decode(d, hex("FF")).empty());
    const auto a = decode(d, hex("00"));
    EXPECT_TRUE(a.empty());
    const auto b = decode(d, hex("7E FF"));
    ASSERT_EQ(b.size(), 1U);
    EXPECT_EQ(b[0], (RxChar{0x7E, true}));
    const auto c = decode(d, hex("FF"));
    ASSERT_EQ(c.size(), 1U);
    EXPECT_EQ(c[0], (RxChar{0xFF, false}));
}

TEST(Parmrk, UnexpectedSequenceKeepsBothBytes) {
    ParmrkDecoder d;
    EXPECT_TRUE(decode(d, hex("FF")).empty());
    const auto out = decode(d, hex("12"));
    ASSERT_EQ(out.size(), 2U);
    EXPECT_EQ(out[0], (RxChar{0xFF, false}));
    EXPECT_EQ(out[1], (RxChar{0x12, false}));
}

TEST(Parmrk, ResetForgetsAPendingMark) {
    ParmrkDecoder d;
    EXPECT_TRUE(decode(d, hex("FF")).empty());
    d.reset();
    const auto out = decode(d, hex("00 01"));
    ASSERT_EQ(out.size(), 2U);
    EXPECT_EQ(out[0], (RxChar{0x00, false}));
}

TEST(Parmrk, CountAgreesWithDecodeAndKeepsState) {
    ParmrkDecoder d;
    ASSERT_EQ(decode(d, hex("01 FF")).size(), 1U);  // leaves a 0xFF pending
    const auto raw = hex("00 41 FF FF 12 FF 00 00 FF 34");
    const std::size_t counted = d.count(raw);
    EXPECT_EQ(counted, d.count(raw));  // count() does not move the decoder on
    const auto out = decode(d, raw);
    EXPECT_EQ(out.size(), counted);
    // Pending 0xFF + 00 → marked 0x41; FF FF → 0xFF; 12; FF 00 00 → break; FF 34 → FF, 34.
    ASSERT_EQ(out.size(), 6U);
    EXPECT_EQ(out[0], (RxChar{0x41, true}));
    EXPECT_EQ(out[3], (RxChar{0x00, true}));
    EXPECT_EQ(out[5], (RxChar{0x34, false}));
}

}  // namespace
}  // namespace drivebus::rtu
