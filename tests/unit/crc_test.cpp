// SPDX-License-Identifier: Apache-2.0
#include "rtu/crc.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "hex.hpp"

namespace drivebus::rtu {
namespace {

using test::hex;

// Bitwise CRC exactly as the Altivar 58 manual describes it, to check the table against.
std::uint16_t crc_by_the_manual(const std::vector<std::uint8_t>& bytes) {
    std::uint16_t crc = 0xFFFF;
    for (const std::uint8_t byte : bytes) {
        crc ^= byte;
        for (int i = 0; i < 8; ++i) {
            const bool out = (crc & 1U) != 0;
            crc = static_cast<std::uint16_t>(crc >> 1U);
            if (out) {
                crc ^= 0xA001;
            }
        }
    }
    return crc;
}

TEST(Crc16, EmptyInputIsTheInitialValue) {
    EXPECT_EQ(crc16({}), 0xFFFF);
}

TEST(Crc16, StandardCheckValue) {
    // CRC-16/MODBUS check value: the CRC of ASCII "123456789" is 0x4B37.
    const std::vector<std::uint8_t> digits{'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    EXPECT_EQ(crc16(digits), 0x4B37);
}

TEST(Crc16, TableMatchesTheBitwiseAlgorithmForEverySingleByte) {
    for (unsigned b = 0; b < 256; ++b) {
        const std::vector<std::uint8_t> one{static_cast<std::uint8_t>(b)};
        EXPECT_EQ(crc16(one), crc_by_the_manual(one)) << "byte " << b;
    }
}

TEST(Crc16, TableMatchesTheBitwiseAlgorithmOnLongInput) {
    std::vector<std::uint8_t> data(300);
    for (std::size_t i = 0; i < data.size(); ++i) {
        data[i] = static_cast<std::uint8_t>(i * 37U + 11U);
    }
    EXPECT_EQ(crc16(data), crc_by_the_manual(data));
}

TEST(Crc16, UpdateContinuesAcrossPieces) {
    const auto frame = hex("01 03 FD 00 00 01");
    const auto first = std::span(frame).first(2);
    const auto rest = std::span(frame).subspan(2);
    EXPECT_EQ(crc16_update(crc16(first), rest), crc16(frame));
}

TEST(Crc16, CrcIsSentLowByteFirst) {
    // Altivar 21 guide, FD00 read: the CRC 0xA6B5 goes on the wire as B5 A6.
    EXPECT_EQ(crc16(hex("01 03 FD 00 00 01")), 0xA6B5);
    EXPECT_TRUE(crc_ok(hex("01 03 FD 00 00 01 B5 A6")));
    EXPECT_FALSE(crc_ok(hex("01 03 FD 00 00 01 A6 B5")));
}

TEST(Crc16, CrcOkRejectsFramesTooShortToCarryOne) {
    EXPECT_FALSE(crc_ok(hex("")));
    EXPECT_FALSE(crc_ok(hex("FF")));
    EXPECT_FALSE(crc_ok(hex("FF FF")));
}

TEST(Crc16, EverySingleBitFlipIsDetected) {
    const auto good = hex("01 10 FA 01 00 01 02 17 70 F3 9A");
    ASSERT_TRUE(crc_ok(good));
    for (std::size_t byte = 0; byte < good.size(); ++byte) {
        for (unsigned bit = 0; bit < 8; ++bit) {
            auto bad = good;
            bad[byte] = static_cast<std::uint8_t>(bad[byte] ^ (1U << bit));
            EXPECT_FALSE(crc_ok(bad)) << "byte " << byte << " bit " << bit;
        }
    }
}

}  // namespace
}  // namespace drivebus::rtu
