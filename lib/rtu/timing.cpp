// SPDX-License-Identifier: Apache-2.0
#include "rtu/timing.hpp"

namespace drivebus::rtu {
namespace {
constexpr std::int64_t kNanosPerSecond = 1'000'000'000;

// Rounded to the nearest nanosecond: numerator / denominator.
Duration rounded(std::int64_t numerator, std::int64_t denominator) noexcept {
    return Duration((numerator + denominator / 2) / denominator);
}
}  // namespace

std::string_view to_string(LineFormatError error) noexcept {
    switch (error) {
    case LineFormatError::InvalidBaud: return "baud rate must be between 50 and 4000000";
    case LineFormatError::InvalidDataBits: return "data bits must be 5 to 8";
    case LineFormatError::InvalidStopBits: return "stop bits must be 1 or 2";
    }
    return "invalid line format";
}

unsigned bits_per_character(const LineFormat& format) noexcept {
    return 1U + format.data_bits + (format.parity == Parity::None ? 0U : 1U) + format.stop_bits;
}

std::expected<CharacterTiming, LineFormatError> character_timing(const LineFormat& format) {
    if (format.baud < 50 || format.baud > 4'000'000) {
        return std::unexpected(LineFormatError::InvalidBaud);
    }
    if (format.data_bits < 5 || format.data_bits > 8) {
        return std::unexpected(LineFormatError::InvalidDataBits);
    }
    if (format.stop_bits < 1 || format.stop_bits > 2) {
        return std::unexpected(LineFormatError::InvalidStopBits);
    }
    const auto bits = static_cast<std::int64_t>(bits_per_character(format));
    const auto baud = static_cast<std::int64_t>(format.baud);
    CharacterTiming timing;
    timing.character = rounded(bits * kNanosPerSecond, baud);
    if (format.baud > kFixedTimingAbove) {
        timing.t1_5 = kFixedT15;
        timing.t3_5 = kFixedT35;
    } else {
        timing.t1_5 = rounded(3 * bits * kNanosPerSecond, 2 * baud);
        timing.t3_5 = rounded(7 * bits * kNanosPerSecond, 2 * baud);
    }
    return timing;
}

Duration wire_time(const CharacterTiming& timing, std::size_t bytes) noexcept {
    return timing.character * static_cast<std::int64_t>(bytes);
}

}  // namespace drivebus::rtu
