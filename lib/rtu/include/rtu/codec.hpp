// SPDX-License-Identifier: Apache-2.0
// Modbus RTU ADU encoding and decoding for both ends of the line.
// Pure functions: bytes and values in, bytes, values or typed errors out.
#pragma once

#include <cstddef>
#include <expected>
#include <span>

#include "rtu/errors.hpp"
#include "rtu/limits.hpp"
#include "rtu/pdu.hpp"
#include "rtu/types.hpp"

namespace drivebus::rtu {

// ---- master side ----

// Checks a request against the spec and the addressed drive's limits.
[[nodiscard]] std::expected<void, ValidationError> validate_request(
    const RequestAdu& request, const FunctionLimits& limits = FunctionLimits::modbus_spec());

// Validates, then builds the frame with its CRC.
[[nodiscard]] std::expected<Adu, ValidationError> encode_request(
    const RequestAdu& request, const FunctionLimits& limits = FunctionLimits::modbus_spec());

// The length of the reply a request can get.
struct ReplyLength {
    enum class Kind : std::uint8_t {
        None,      // broadcast: no reply
        Fixed,     // `length` bytes for a normal reply
        Variable,  // FC43/14: between `length` and `max_length`, see reply_bytes_needed()
    };
    Kind kind = Kind::None;
    std::size_t length = 0;
    std::size_t max_length = 0;
    static constexpr std::size_t kException = 5;
};
[[nodiscard]] ReplyLength expected_reply_length(const RequestAdu& request) noexcept;

// How many bytes the reply to `request` needs in total, judging from the bytes received so
// far (at least 1 more than received while its header is incomplete). Returns 0 when the
// received bytes cannot be the start of a reply to this request (wrong slave or function):
// the caller then frames by silence.
[[nodiscard]] std::size_t reply_bytes_needed(const RequestAdu& request,
                                             std::span<const std::uint8_t> received) noexcept;

// Decodes a complete reply frame to `request`: CRC, address, function, lengths and echoes.
[[nodiscard]] std::expected<ResponseAdu, DecodeError> decode_response(const RequestAdu& request,
                                                                      std::span<const std::uint8_t> frame);

// ---- slave side ----

// Decodes a complete request frame. exception_for() tells how a slave answers a failure.
[[nodiscard]] std::expected<RequestAdu, DecodeError> decode_request(std::span<const std::uint8_t> frame);

// Builds a reply frame with its CRC.
[[nodiscard]] std::expected<Adu, ValidationError> encode_response(const ResponseAdu& response);

}  // namespace drivebus::rtu
