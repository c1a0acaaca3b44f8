// SPDX-License-Identifier: Apache-2.0
#include "rtu/crc.hpp"

#include <array>

namespace drivebus::rtu {
namespace {

constexpr std::uint16_t kPolynomial = 0xA001;

constexpr std::array<std::uint16_t, 256> make_table() noexcept {
    std::array<std::uint16_t, 256> table{};
    for (std::uint32_t i = 0; i < table.size(); ++i) {
        auto crc = static_cast<std::uint16_t>(i);
        for (int bit = 0; bit < 8; ++bit) {
            const bool lsb = (crc & 1U) != 0;
            crc = static_cast<std::uint16_t>(crc >> 1U);
            if (lsb) {
                crc ^= kPolynomial;
            }
        }
        table[i] = crc;
    }
    return table;
}

constexpr auto kTable = make_table();

}  // namespace

std::uint16_t crc16_update(std::uint16_t crc, std::span<const std::uint8_t> bytes) noexcept {
    for (const std::uint8_t byte : bytes) {
        crc = static_cast<std::uint16_t>((crc >> 8U) ^ kTable[(crc ^ byte) & 0xFFU]);
    }
    return crc;
}

std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept {
    return crc16_update(kCrcInit, bytes);
}

bool crc_ok(std::span<const std::uint8_t> frame) noexcept {
    if (frame.size() < 3) {
        return false;
    }
    const std::size_t body = frame.size() - 2;
    const std::uint16_t crc = crc16(frame.first(body));
    return frame[body] == (crc & 0xFFU) && frame[body + 1] == (crc >> 8U);
}

}  // namespace drivebus::rtu
