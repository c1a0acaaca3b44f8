// SPDX-License-Identifier: Apache-2.0
// Bounds-checked big-endian reader over a frame; every read reports running out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>

#include "rtu/crc.hpp"
#include "rtu/errors.hpp"
#include "rtu/types.hpp"

namespace drivebus::rtu::detail {

class ByteReader {
public:
    explicit ByteReader(std::span<const std::uint8_t> bytes) noexcept : bytes_(bytes) {}

    [[nodiscard]] std::size_t remaining() const noexcept { return bytes_.size() - pos_; }
    [[nodiscard]] std::size_t position() const noexcept { return pos_; }

    std::optional<std::uint8_t> u8() noexcept {
        if (remaining() < 1) {
            return std::nullopt;
        }
        return bytes_[pos_++];
    }

    std::optional<std::uint16_t> u16() noexcept {
        if (remaining() < 2) {
            return std::nullopt;
        }
        const auto hi = static_cast<std::uint16_t>(bytes_[pos_] << 8U);
        const auto value = static_cast<std::uint16_t>(hi | bytes_[pos_ + 1]);
        pos_ += 2;
        return value;
    }

    std::optional<std::span<const std::uint8_t>> take(std::size_t n) noexcept {
        if (remaining() < n) {
            return std::nullopt;
        }
        auto out = bytes_.subspan(pos_, n);
        pos_ += n;
        return out;
    }

private:
    std::span<const std::uint8_t> bytes_;
    std::size_t pos_ = 0;
};

// The checks every received frame passes first: size within 4-256 bytes and a good CRC.
// Returns the PDU after the function code, without the CRC.
inline std::expected<std::span<const std::uint8_t>, DecodeError> checked_body(std::span<const std::uint8_t> frame) {
    if (frame.size() > kMaxAduSize) {
        return std::unexpected(DecodeError::TooLong);
    }
    if (frame.size() < kMinAduSize) {
        return std::unexpected(DecodeError::TooShort);
    }
    if (!crc_ok(frame)) {
        return std::unexpected(DecodeError::CrcMismatch);
    }
    return frame.subspan(2, frame.size() - 4);
}

}  // namespace drivebus::rtu::detail
