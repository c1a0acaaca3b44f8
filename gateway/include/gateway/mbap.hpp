// SPDX-License-Identifier: Apache-2.0
// Modbus TCP framing (MBAP): a 7-byte header (transaction id, protocol id 0, length, unit id)
// before each PDU. Pure: bytes in, ADUs or a typed error out; the server owns the socket.
#pragma once

#include <cstddef>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <vector>

namespace drivebus::gateway {

inline constexpr std::size_t kMbapHeaderSize = 7;  // transaction, protocol, length, unit
inline constexpr std::size_t kMaxPduSize = 253;    // as on the serial line: the ADU fits 260 bytes
inline constexpr std::size_t kMaxAduSize = kMbapHeaderSize + kMaxPduSize;

struct Adu {
    std::uint16_t transaction = 0;
    std::uint8_t unit = 0;
    std::vector<std::uint8_t> pdu;  // the function code first
};

// What makes a stream unusable: nothing after it can be framed, so the connection is closed.
enum class StreamError : std::uint8_t {
    ProtocolId,  // not 0: not Modbus
    Length,      // the length field is below 2 (unit id and function) or above 254
};

[[nodiscard]] const char* to_string(StreamError error) noexcept;

// Splits a connection's bytes into ADUs. It holds at most the bytes given and not yet taken:
// the server gives it one read at a time and takes the ADUs before reading again.
class MbapReader {
public:
    void feed(std::span<const std::uint8_t> bytes);
    // The next complete ADU, nothing when the rest has not arrived, or why the stream is broken.
    [[nodiscard]] std::expected<std::optional<Adu>, StreamError> next();
    // Bytes held that are not a complete ADU yet.
    [[nodiscard]] std::size_t pending() const noexcept { return buffer_.size() - taken_; }

private:
    std::vector<std::uint8_t> buffer_;
    std::size_t taken_ = 0;
};

// An ADU on the wire: header and PDU (at most kMaxPduSize bytes).
[[nodiscard]] std::vector<std::uint8_t> encode(std::uint16_t transaction, std::uint8_t unit,
                                               std::span<const std::uint8_t> pdu);

}  // namespace drivebus::gateway
