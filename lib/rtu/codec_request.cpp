// SPDX-License-Identifier: Apache-2.0
// Requests: validation and encoding (master), decoding (slave).
#include <algorithm>
#include <array>

#include "rtu/byte_reader.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"

namespace drivebus::rtu {
namespace {

constexpr std::uint32_t kRegisterSpace = 0x10000;

bool in_window(const FunctionLimits& limits, FunctionCode function, std::uint16_t start,
               std::size_t quantity) noexcept {
    return std::ranges::any_of(limits.windows, [&](const BlockWindow& w) {
        return w.function == function && w.start == start && quantity >= w.min_quantity && quantity <= w.max_quantity;
    });
}

std::expected<void, ValidationError> check_quantity(const FunctionLimits& limits, FunctionCode function,
                                                    std::uint16_t start, std::size_t quantity, std::uint16_t spec_max,
                                                    std::uint16_t drive_max) {
    if (quantity < 1 || quantity > spec_max) {
        return std::unexpected(ValidationError::QuantityOutOfRange);
    }
    if (start + quantity > kRegisterSpace) {
        return std::unexpected(ValidationError::AddressRangeOverflow);
    }
    if (quantity > drive_max && !in_window(limits, function, start, quantity)) {
        return std::unexpected(ValidationError::QuantityAboveDriveLimit);
    }
    return {};
}

struct Validator {
    const FunctionLimits& limits;
    bool broadcast;

    std::expected<void, ValidationError> operator()(const ReadHoldingRegisters& r) const {
        if (!limits.read_holding) {
            return std::unexpected(ValidationError::FunctionNotSupported);
        }
        if (broadcast) {
            return std::unexpected(ValidationError::BroadcastNotAllowed);
        }
        return check_quantity(limits, FunctionCode::ReadHoldingRegisters, r.start, r.quantity, kMaxReadRegisters,
                              limits.max_read);
    }
    std::expected<void, ValidationError> operator()(const WriteSingleRegister&) const {
        if (!limits.write_single) {
            return std::unexpected(ValidationError::FunctionNotSupported);
        }
        if (broadcast && !limits.broadcast_write_single) {
            return std::unexpected(ValidationError::BroadcastNotAllowed);
        }
        return {};
    }
    std::expected<void, ValidationError> operator()(const WriteMultipleRegisters& w) const {
        if (!limits.write_multiple) {
            return std::unexpected(ValidationError::FunctionNotSupported);
        }
        if (broadcast && !limits.broadcast_write_multiple) {
            return std::unexpected(ValidationError::BroadcastNotAllowed);
        }
        return check_quantity(limits, FunctionCode::WriteMultipleRegisters, w.start, w.values.size(),
                              kMaxWriteRegisters, limits.max_write);
    }
    std::expected<void, ValidationError> operator()(const ReadDeviceIdentification& r) const {
        if (!limits.device_identification) {
            return std::unexpected(ValidationError::FunctionNotSupported);
        }
        if (broadcast) {
            return std::unexpected(ValidationError::BroadcastNotAllowed);
        }
        const auto code = static_cast<std::uint8_t>(r.code);
        if (code < 1 || code > 4) {
            return std::unexpected(ValidationError::InvalidDeviceIdCode);
        }
        return {};
    }
};

struct PduWriter {
    Adu& adu;

    bool operator()(const ReadHoldingRegisters& r) const {
        return adu.push_back(0x03) && adu.append_u16(r.start) && adu.append_u16(r.quantity);
    }
    bool operator()(const WriteSingleRegister& w) const {
        return adu.push_back(0x06) && adu.append_u16(w.address) && adu.append_u16(w.value);
    }
    bool operator()(const WriteMultipleRegisters& w) const {
        const auto quantity = static_cast<std::uint16_t>(w.values.size());
        bool ok = adu.push_back(0x10) && adu.append_u16(w.start) && adu.append_u16(quantity) &&
                  adu.push_back(static_cast<std::uint8_t>(quantity * 2U));
        for (const std::uint16_t v : w.values.words()) {
            ok = ok && adu.append_u16(v);
        }
        return ok;
    }
    bool operator()(const ReadDeviceIdentification& r) const {
        return adu.push_back(static_cast<std::uint8_t>(FunctionCode::EncapsulatedInterface)) &&
               adu.push_back(kMeiReadDeviceIdentification) && adu.push_back(static_cast<std::uint8_t>(r.code)) &&
               adu.push_back(r.object_id);
    }
};

std::expected<Request, DecodeError> decode_read(detail::ByteReader& in) {
    const auto start = in.u16();
    const auto quantity = in.u16();
    if (!start || !quantity || in.remaining() != 0) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    if (*quantity < 1 || *quantity > kMaxReadRegisters) {
        return std::unexpected(DecodeError::QuantityOutOfRange);
    }
    return ReadHoldingRegisters{*start, *quantity};
}

std::expected<Request, DecodeError> decode_write_single(detail::ByteReader& in) {
    const auto address = in.u16();
    const auto value = in.u16();
    if (!address || !value || in.remaining() != 0) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    return WriteSingleRegister{*address, *value};
}

std::expected<Request, DecodeError> decode_write_multiple(detail::ByteReader& in) {
    const auto start = in.u16();
    const auto quantity = in.u16();
    const auto byte_count = in.u8();
    if (!start || !quantity || !byte_count) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    if (*quantity < 1 || *quantity > kMaxWriteRegisters) {
        return std::unexpected(DecodeError::QuantityOutOfRange);
    }
    if (*byte_count != *quantity * 2U) {
        return std::unexpected(DecodeError::ByteCountMismatch);
    }
    if (in.remaining() != *byte_count) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    WriteMultipleRegisters request{*start, {}};
    for (std::uint16_t i = 0; i < *quantity; ++i) {
        request.values.push_back(*in.u16());
    }
    return request;
}

std::expected<Request, DecodeError> decode_device_id_request(detail::ByteReader& in) {
    const auto mei = in.u8();
    if (!mei) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    if (*mei != kMeiReadDeviceIdentification) {
        return std::unexpected(DecodeError::InvalidMeiType);
    }
    const auto code = in.u8();
    const auto object = in.u8();
    if (!code || !object || in.remaining() != 0) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    if (*code < 1 || *code > 4) {
        return std::unexpected(DecodeError::InvalidDeviceIdCode);
    }
    return ReadDeviceIdentification{static_cast<DeviceIdCode>(*code), *object};
}

}  // namespace

FunctionCode function_of(const Request& request) noexcept {
    // By index rather than std::visit, which may throw on a valueless variant.
    static constexpr std::array<FunctionCode, std::variant_size_v<Request>> kCodes{
        FunctionCode::ReadHoldingRegisters, FunctionCode::WriteSingleRegister, FunctionCode::WriteMultipleRegisters,
        FunctionCode::EncapsulatedInterface};
    return kCodes[request.index() % kCodes.size()];
}

std::expected<void, ValidationError> validate_request(const RequestAdu& request, const FunctionLimits& limits) {
    const bool broadcast = request.address == kBroadcastAddress;
    if (!broadcast && (request.address > kMaxUnicastAddress || request.address > limits.max_address)) {
        return std::unexpected(ValidationError::InvalidSlaveAddress);
    }
    return std::visit(Validator{limits, broadcast}, request.pdu);
}

std::expected<Adu, ValidationError> encode_request(const RequestAdu& request, const FunctionLimits& limits) {
    if (auto valid = validate_request(request, limits); !valid) {
        return std::unexpected(valid.error());
    }
    Adu adu;
    if (!adu.push_back(request.address) || !std::visit(PduWriter{adu}, request.pdu) || !adu.append_crc()) {
        return std::unexpected(ValidationError::AduTooLong);
    }
    return adu;
}

std::expected<RequestAdu, DecodeError> decode_request(std::span<const std::uint8_t> frame) {
    const auto body = detail::checked_body(frame);
    if (!body) {
        return std::unexpected(body.error());
    }
    const std::uint8_t address = frame[0];
    const std::uint8_t function = frame[1];
    detail::ByteReader in(*body);

    std::expected<Request, DecodeError> pdu = std::unexpected(DecodeError::UnknownFunction);
    switch (function) {
    case 0x03: pdu = decode_read(in); break;
    case 0x06: pdu = decode_write_single(in); break;
    case 0x10: pdu = decode_write_multiple(in); break;
    case 0x2B: pdu = decode_device_id_request(in); break;
    default: break;
    }
    if (!pdu) {
        return std::unexpected(pdu.error());
    }
    return RequestAdu{address, *pdu};
}

}  // namespace drivebus::rtu
