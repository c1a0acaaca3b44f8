// SPDX-License-Identifier: Apache-2.0
// CRC16 of Modbus RTU: polynomial 0xA001 (reflected 0x8005), initial value 0xFFFF,
// transmitted low byte first.
#pragma once

#include <cstdint>
#include <span>

namespace drivebus::rtu {

[[nodiscard]] std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept;

// Continues a CRC over more bytes (start with kCrcInit).
inline constexpr std::uint16_t kCrcInit = 0xFFFF;
[[nodiscard]] std::uint16_t crc16_update(std::uint16_t crc, std::span<const std::uint8_t> bytes) noexcept;

// True when the last two bytes are the CRC of the bytes before them (low byte first).
[[nodiscard]] bool crc_ok(std::span<const std::uint8_t> frame) noexcept;

}  // namespace drivebus::rtu
