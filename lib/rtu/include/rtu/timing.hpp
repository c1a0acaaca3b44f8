// SPDX-License-Identifier: Apache-2.0
// Character timing of an asynchronous serial line and the Modbus RTU silences derived from it.
#pragma once

#include <chrono>
#include <cstdint>
#include <expected>
#include <string_view>

namespace drivebus::rtu {

// CLOCK_MONOTONIC on Linux. The pure layers only ever receive times as arguments.
using Clock = std::chrono::steady_clock;
using Instant = Clock::time_point;
using Duration = std::chrono::nanoseconds;

enum class Parity : std::uint8_t { None, Even, Odd };

struct LineFormat {
    std::uint32_t baud = 19200;
    std::uint8_t data_bits = 8;
    Parity parity = Parity::Even;
    std::uint8_t stop_bits = 1;
    friend bool operator==(const LineFormat&, const LineFormat&) = default;
};

enum class LineFormatError : std::uint8_t { InvalidBaud, InvalidDataBits, InvalidStopBits };
[[nodiscard]] std::string_view to_string(LineFormatError error) noexcept;

// Bits on the wire per character: start + data + parity (0/1) + stop.
[[nodiscard]] unsigned bits_per_character(const LineFormat& format) noexcept;

struct CharacterTiming {
    Duration character{};  // one character on the wire
    Duration t1_5{};       // longest silence allowed inside a frame
    Duration t3_5{};       // silence that ends a frame and must precede the next one
    friend bool operator==(const CharacterTiming&, const CharacterTiming&) = default;
};

// Modbus over serial line V1.02, 2.5.1.1: 1.5 and 3.5 character times up to 19200 bit/s,
// fixed 750 us and 1750 us above, where the UART's own timing granularity dominates.
inline constexpr std::uint32_t kFixedTimingAbove = 19200;
inline constexpr Duration kFixedT15 = std::chrono::microseconds(750);
inline constexpr Duration kFixedT35 = std::chrono::microseconds(1750);

[[nodiscard]] std::expected<CharacterTiming, LineFormatError> character_timing(const LineFormat& format);

// Wire time of `bytes` characters sent back to back.
[[nodiscard]] Duration wire_time(const CharacterTiming& timing, std::size_t bytes) noexcept;

}  // namespace drivebus::rtu
