// SPDX-License-Identifier: Apache-2.0
// Typed errors of the codec. Every failure has a name; none is a bare bool or errno.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "rtu/types.hpp"

namespace drivebus::rtu {

// Why a request (or a response a slave builds) cannot be put on the wire.
enum class ValidationError : std::uint8_t {
    InvalidSlaveAddress,      // 248-255, or above the drive's range
    BroadcastNotAllowed,      // address 0 with a function that may not be broadcast
    FunctionNotSupported,     // the drive's limits exclude this function
    QuantityOutOfRange,       // outside the spec: FC03 1-125, FC16 1-123
    QuantityAboveDriveLimit,  // inside the spec but above the drive's own limit
    AddressRangeOverflow,     // start + quantity runs past register 0xFFFF
    InvalidDeviceIdCode,      // FC43/14 read code outside 1-4
    InvalidExceptionCode,     // exception response with code 0 or a flagged function
    AduTooLong,               // the frame would exceed 256 bytes
};

// Why received bytes are not a valid frame of the expected kind.
enum class DecodeError : std::uint8_t {
    TooShort,  // fewer bytes than the smallest frame of its kind
    TooLong,   // more than 256 bytes
    CrcMismatch,
    UnexpectedSlave,      // reply from another address than the one asked
    UnexpectedFunction,   // reply function is neither the request's nor its exception
    UnknownFunction,      // request function this codec does not implement
    InvalidMeiType,       // FC43 with a MEI type other than 14
    InvalidDeviceIdCode,  // FC43/14 read code outside 1-4
    QuantityOutOfRange,   // request quantity outside the spec limits
    ByteCountMismatch,    // byte count field disagrees with the quantity
    LengthMismatch,       // frame length disagrees with its own fields
    EchoMismatch,         // FC06/FC16/FC43 reply does not echo the request's fields
    ObjectOverrun,        // FC43 object length runs past the end of the frame
    InvalidField,         // a field holds a value the spec does not allow
};

[[nodiscard]] std::string_view to_string(ValidationError error) noexcept;
[[nodiscard]] std::string_view to_string(DecodeError error) noexcept;

// The exception a slave answers for a request that failed to decode, per the Modbus
// application protocol's state diagrams; nullopt when the frame must be ignored silently
// (broken frames get no answer).
[[nodiscard]] std::optional<ExceptionCode> exception_for(DecodeError error) noexcept;

}  // namespace drivebus::rtu
