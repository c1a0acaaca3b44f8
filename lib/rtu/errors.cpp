// SPDX-License-Identifier: Apache-2.0
#include "rtu/errors.hpp"

namespace drivebus::rtu {

std::string_view to_string(ValidationError error) noexcept {
    switch (error) {
    case ValidationError::InvalidSlaveAddress: return "slave address out of range";
    case ValidationError::BroadcastNotAllowed: return "function may not be broadcast";
    case ValidationError::FunctionNotSupported: return "function not supported by the drive";
    case ValidationError::QuantityOutOfRange: return "quantity outside the Modbus limits";
    case ValidationError::QuantityAboveDriveLimit: return "quantity above the drive's limit";
    case ValidationError::AddressRangeOverflow: return "register range runs past 0xFFFF";
    case ValidationError::InvalidDeviceIdCode: return "device identification code outside 1-4";
    case ValidationError::InvalidExceptionCode: return "invalid exception response";
    case ValidationError::AduTooLong: return "frame longer than 256 bytes";
    }
    return "unknown validation error";
}

std::string_view to_string(DecodeError error) noexcept {
    switch (error) {
    case DecodeError::TooShort: return "frame too short";
    case DecodeError::TooLong: return "frame longer than 256 bytes";
    case DecodeError::CrcMismatch: return "CRC mismatch";
    case DecodeError::UnexpectedSlave: return "reply from an unexpected slave";
    case DecodeError::UnexpectedFunction: return "reply with an unexpected function code";
    case DecodeError::UnknownFunction: return "unknown function code";
    case DecodeError::InvalidMeiType: return "MEI type is not 14";
    case DecodeError::InvalidDeviceIdCode: return "device identification code outside 1-4";
    case DecodeError::QuantityOutOfRange: return "quantity outside the Modbus limits";
    case DecodeError::ByteCountMismatch: return "byte count disagrees with the quantity";
    case DecodeError::LengthMismatch: return "frame length disagrees with its fields";
    case DecodeError::EchoMismatch: return "reply does not echo the request";
    case DecodeError::ObjectOverrun: return "identification object runs past the frame";
    case DecodeError::InvalidField: return "field value not allowed by the Modbus specification";
    }
    return "unknown decode error";
}

std::optional<ExceptionCode> exception_for(DecodeError error) noexcept {
    switch (error) {
    case DecodeError::UnknownFunction:
    case DecodeError::InvalidMeiType: return ExceptionCode::IllegalFunction;
    case DecodeError::InvalidDeviceIdCode:
    case DecodeError::QuantityOutOfRange:
    case DecodeError::ByteCountMismatch:
    case DecodeError::LengthMismatch: return ExceptionCode::IllegalDataValue;
    case DecodeError::TooShort:
    case DecodeError::TooLong:
    case DecodeError::CrcMismatch:
    case DecodeError::UnexpectedSlave:
    case DecodeError::UnexpectedFunction:
    case DecodeError::EchoMismatch:
    case DecodeError::ObjectOverrun:
    case DecodeError::InvalidField: return std::nullopt;
    }
    return std::nullopt;
}

}  // namespace drivebus::rtu
