// SPDX-License-Identifier: Apache-2.0
// Responses: decoding and reply lengths (master), encoding (slave).
#include "rtu/byte_reader.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"
#include "rtu/device_id.hpp"

namespace drivebus::rtu {
namespace {

constexpr std::size_t kWriteReplyLength = 8;  // address, function, 2 x u16, CRC

std::uint8_t code_of(const Request& request) noexcept {
    return static_cast<std::uint8_t>(function_of(request));
}

struct ReplyDecoder {
    detail::ByteReader& in;

    std::expected<Response, DecodeError> operator()(const ReadHoldingRegisters& r) const {
        const auto byte_count = in.u8();
        if (!byte_count) {
            return std::unexpected(DecodeError::TooShort);
        }
        if (*byte_count != r.quantity * 2U) {
            return std::unexpected(DecodeError::ByteCountMismatch);
        }
        if (in.remaining() != *byte_count) {
            return std::unexpected(DecodeError::LengthMismatch);
        }
        ReadHoldingRegistersResponse response;
        for (std::uint16_t i = 0; i < r.quantity; ++i) {
            response.values.push_back(*in.u16());
        }
        return response;
    }
    std::expected<Response, DecodeError> operator()(const WriteSingleRegister& w) const {
        const auto address = in.u16();
        const auto value = in.u16();
        if (!address || !value || in.remaining() != 0) {
            return std::unexpected(DecodeError::LengthMismatch);
        }
        if (*address != w.address || *value != w.value) {
            return std::unexpected(DecodeError::EchoMismatch);
        }
        return WriteSingleRegisterResponse{*address, *value};
    }
    std::expected<Response, DecodeError> operator()(const WriteMultipleRegisters& w) const {
        const auto start = in.u16();
        const auto quantity = in.u16();
        if (!start || !quantity || in.remaining() != 0) {
            return std::unexpected(DecodeError::LengthMismatch);
        }
        if (*start != w.start || *quantity != w.values.size()) {
            return std::unexpected(DecodeError::EchoMismatch);
        }
        return WriteMultipleRegistersResponse{*start, *quantity};
    }
    std::expected<Response, DecodeError> operator()(const ReadDeviceIdentification& r) const {
        auto response = detail::decode_device_id(in);
        if (!response) {
            return std::unexpected(response.error());
        }
        if (response->code != r.code) {
            return std::unexpected(DecodeError::EchoMismatch);
        }
        return std::move(*response);
    }
};

struct ReplyWriter {
    Adu& adu;

    bool operator()(const ReadHoldingRegistersResponse& r) const {
        bool ok = adu.push_back(0x03) && adu.push_back(static_cast<std::uint8_t>(r.values.size() * 2));
        for (const std::uint16_t v : r.values.words()) {
            ok = ok && adu.append_u16(v);
        }
        return ok;
    }
    bool operator()(const WriteSingleRegisterResponse& w) const {
        return adu.push_back(0x06) && adu.append_u16(w.address) && adu.append_u16(w.value);
    }
    bool operator()(const WriteMultipleRegistersResponse& w) const {
        return adu.push_back(0x10) && adu.append_u16(w.start) && adu.append_u16(w.quantity);
    }
    bool operator()(const DeviceIdentificationResponse& d) const {
        return adu.push_back(static_cast<std::uint8_t>(FunctionCode::EncapsulatedInterface)) &&
               detail::encode_device_id(adu, d);
    }
    bool operator()(const ExceptionResponse& e) const {
        return adu.push_back(static_cast<std::uint8_t>(e.function | kExceptionFlag)) &&
               adu.push_back(static_cast<std::uint8_t>(e.code));
    }
};

struct ReplyValidator {
    std::expected<void, ValidationError> operator()(const ReadHoldingRegistersResponse& r) const {
        if (r.values.size() < 1 || r.values.size() > kMaxReadRegisters) {
            return std::unexpected(ValidationError::QuantityOutOfRange);
        }
        return {};
    }
    std::expected<void, ValidationError> operator()(const WriteSingleRegisterResponse&) const { return {}; }
    std::expected<void, ValidationError> operator()(const WriteMultipleRegistersResponse& w) const {
        if (w.quantity < 1 || w.quantity > kMaxWriteRegisters) {
            return std::unexpected(ValidationError::QuantityOutOfRange);
        }
        return {};
    }
    std::expected<void, ValidationError> operator()(const DeviceIdentificationResponse& d) const {
        const auto code = static_cast<std::uint8_t>(d.code);
        if (code < 1 || code > 4) {
            return std::unexpected(ValidationError::InvalidDeviceIdCode);
        }
        return {};
    }
    std::expected<void, ValidationError> operator()(const ExceptionResponse& e) const {
        if ((e.function & kExceptionFlag) != 0 || e.function == 0 || static_cast<std::uint8_t>(e.code) == 0) {
            return std::unexpected(ValidationError::InvalidExceptionCode);
        }
        return {};
    }
};

}  // namespace

ReplyLength expected_reply_length(const RequestAdu& request) noexcept {
    if (request.address == kBroadcastAddress) {
        return {};
    }
    if (const auto* read = std::get_if<ReadHoldingRegisters>(&request.pdu)) {
        return {ReplyLength::Kind::Fixed, 5U + 2U * read->quantity, 5U + 2U * read->quantity};
    }
    if (std::holds_alternative<ReadDeviceIdentification>(request.pdu)) {
        return {ReplyLength::Kind::Variable, 2 + detail::kDeviceIdHeader + 2, kMaxAduSize};
    }
    return {ReplyLength::Kind::Fixed, kWriteReplyLength, kWriteReplyLength};
}

std::size_t reply_bytes_needed(const RequestAdu& request, std::span<const std::uint8_t> received) noexcept {
    const ReplyLength shape = expected_reply_length(request);
    if (shape.kind == ReplyLength::Kind::None) {
        return 0;
    }
    if (received.empty()) {
        return 2;
    }
    if (received[0] != request.address) {
        return 0;
    }
    if (received.size() < 2) {
        return 2;
    }
    const std::uint8_t function = received[1];
    if (function == (code_of(request.pdu) | kExceptionFlag)) {
        return ReplyLength::kException;
    }
    if (function != code_of(request.pdu)) {
        return 0;
    }
    if (shape.kind == ReplyLength::Kind::Fixed) {
        return shape.length <= kMaxAduSize ? shape.length : 0;  // 0 for a request that fails validation
    }
    return detail::device_id_bytes_needed(received);
}

std::expected<ResponseAdu, DecodeError> decode_response(const RequestAdu& request,
                                                        std::span<const std::uint8_t> frame) {
    const auto body = detail::checked_body(frame);
    if (!body) {
        return std::unexpected(body.error());
    }
    const std::uint8_t address = frame[0];
    const std::uint8_t function = frame[1];
    detail::ByteReader in(*body);
    // Broadcasts get no reply, and no slave answers from a reserved address.
    if (address != request.address || address == kBroadcastAddress || address > kMaxUnicastAddress) {
        return std::unexpected(DecodeError::UnexpectedSlave);
    }
    const std::uint8_t expected = code_of(request.pdu);
    if (function == (expected | kExceptionFlag)) {
        const auto code = in.u8();
        if (!code || in.remaining() != 0) {
            return std::unexpected(DecodeError::LengthMismatch);
        }
        return ResponseAdu{address, ExceptionResponse{expected, static_cast<ExceptionCode>(*code)}};
    }
    if (function != expected) {
        return std::unexpected(DecodeError::UnexpectedFunction);
    }
    auto pdu = std::visit(ReplyDecoder{in}, request.pdu);
    if (!pdu) {
        return std::unexpected(pdu.error());
    }
    return ResponseAdu{address, std::move(*pdu)};
}

std::expected<Adu, ValidationError> encode_response(const ResponseAdu& response) {
    if (response.address == kBroadcastAddress || response.address > kMaxUnicastAddress) {
        return std::unexpected(ValidationError::InvalidSlaveAddress);
    }
    if (auto valid = std::visit(ReplyValidator{}, response.pdu); !valid) {
        return std::unexpected(valid.error());
    }
    Adu adu;
    if (!adu.push_back(response.address) || !std::visit(ReplyWriter{adu}, response.pdu) || !adu.append_crc()) {
        return std::unexpected(ValidationError::AduTooLong);
    }
    return adu;
}

}  // namespace drivebus::rtu
