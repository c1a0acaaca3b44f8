// SPDX-License-Identifier: Apache-2.0
// Codec behaviour beyond the seed frames: spec limits, typed errors, reply lengths.
#include <gtest/gtest.h>

#include "hex.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"

namespace drivebus::rtu {
namespace {

using test::hex;
using test::to_hex;

RegisterValues words(std::size_t n) {
    RegisterValues v;
    for (std::size_t i = 0; i < n; ++i) {
        v.push_back(static_cast<std::uint16_t>(i * 257U));
    }
    return v;
}

Adu with_crc(std::string_view body) {
    Adu adu;
    adu.append(hex(body));
    adu.append_crc();
    return adu;
}

TEST(Validation, SlaveAddresses) {
    const ReadHoldingRegisters read{0, 1};
    EXPECT_TRUE(validate_request({1, read}).has_value());
    EXPECT_TRUE(validate_request({247, read}).has_value());
    for (int a = 248; a <= 255; ++a) {
        EXPECT_EQ(validate_request({static_cast<SlaveAddress>(a), read}).error(), ValidationError::InvalidSlaveAddress);
    }
    FunctionLimits small;
    small.max_address = 31;
    EXPECT_EQ(validate_request({32, read}, small).error(), ValidationError::InvalidSlaveAddress);
}

TEST(Validation, OnlyWritesMayBeBroadcast) {
    EXPECT_TRUE(validate_request({0, WriteSingleRegister{1, 2}}).has_value());
    EXPECT_TRUE(validate_request({0, WriteMultipleRegisters{1, words(3)}}).has_value());
    EXPECT_EQ(validate_request({0, ReadHoldingRegisters{1, 1}}).error(), ValidationError::BroadcastNotAllowed);
    EXPECT_EQ(validate_request({0, ReadDeviceIdentification{}}).error(), ValidationError::BroadcastNotAllowed);
    FunctionLimits no_broadcast;
    no_broadcast.broadcast_write_single = false;
    no_broadcast.broadcast_write_multiple = false;
    EXPECT_EQ(validate_request({0, WriteSingleRegister{1, 2}}, no_broadcast).error(),
              ValidationError::BroadcastNotAllowed);
    EXPECT_EQ(validate_request({0, WriteMultipleRegisters{1, words(1)}}, no_broadcast).error(),
              ValidationError::BroadcastNotAllowed);
}

TEST(Validation, SpecQuantityLimits) {
    EXPECT_EQ(validate_request({1, ReadHoldingRegisters{0, 0}}).error(), ValidationError::QuantityOutOfRange);
    EXPECT_TRUE(validate_request({1, ReadHoldingRegisters{0, 125}}).has_value());
    EXPECT_EQ(validate_request({1, ReadHoldingRegisters{0, 126}}).error(), ValidationError::QuantityOutOfRange);
    EXPECT_EQ(validate_request({1, WriteMultipleRegisters{0, words(0)}}).error(), ValidationError::QuantityOutOfRange);
    EXPECT_TRUE(validate_request({1, WriteMultipleRegisters{0, words(123)}}).has_value());
    EXPECT_EQ(validate_request({1, WriteMultipleRegisters{0, words(124)}}).error(),
              ValidationError::QuantityOutOfRange);
}

TEST(Validation, RangeMayNotRunPastTheLastRegister) {
    EXPECT_TRUE(validate_request({1, ReadHoldingRegisters{0xFFFF, 1}}).has_value());
    EXPECT_EQ(validate_request({1, ReadHoldingRegisters{0xFFFF, 2}}).error(), ValidationError::AddressRangeOverflow);
    EXPECT_TRUE(validate_request({1, WriteMultipleRegisters{0xFF85, words(123)}}).has_value());
    EXPECT_EQ(validate_request({1, WriteMultipleRegisters{0xFF86, words(123)}}).error(),
              ValidationError::AddressRangeOverflow);
}

TEST(Validation, FunctionsADriveDoesNotSupport) {
    FunctionLimits limits;
    limits.read_holding = false;
    limits.write_single = false;
    limits.write_multiple = false;
    limits.device_identification = false;
    EXPECT_EQ(validate_request({1, ReadHoldingRegisters{0, 1}}, limits).error(), ValidationError::FunctionNotSupported);
    EXPECT_EQ(validate_request({1, WriteSingleRegister{0, 1}}, limits).error(), ValidationError::FunctionNotSupported);
    EXPECT_EQ(validate_request({1, WriteMultipleRegisters{0, words(1)}}, limits).error(),
              ValidationError::FunctionNotSupported);
    EXPECT_EQ(validate_request({1, ReadDeviceIdentification{}}, limits).error(), ValidationError::FunctionNotSupported);
}

TEST(Validation, DeviceIdentificationCodes) {
    EXPECT_TRUE(validate_request({1, ReadDeviceIdentification{DeviceIdCode::Specific, 0x80}}).has_value());
    EXPECT_EQ(validate_request({1, ReadDeviceIdentification{static_cast<DeviceIdCode>(0), 0}}).error(),
              ValidationError::InvalidDeviceIdCode);
    EXPECT_EQ(validate_request({1, ReadDeviceIdentification{static_cast<DeviceIdCode>(5), 0}}).error(),
              ValidationError::InvalidDeviceIdCode);
}

TEST(Validation, ErrorsHaveNames) {
    for (int e = 0; e <= static_cast<int>(ValidationError::AduTooLong); ++e) {
        EXPECT_NE(to_string(static_cast<ValidationError>(e)), "unknown validation error");
    }
    for (int e = 0; e <= static_cast<int>(DecodeError::InvalidField); ++e) {
        EXPECT_NE(to_string(static_cast<DecodeError>(e)), "unknown decode error");
    }
}

TEST(Encoding, LargestRequestsFitTheAduLimit) {
    const auto write = encode_request({1, WriteMultipleRegisters{0, words(123)}});
    ASSERT_TRUE(write.has_value());
    EXPECT_EQ(write->size(), 9U + 246U);
    const auto read_reply = encode_response({1, ReadHoldingRegistersResponse{words(125)}});
    ASSERT_TRUE(read_reply.has_value());
    EXPECT_EQ(read_reply->size(), 255U);
    EXPECT_EQ(decode_response({1, ReadHoldingRegisters{0, 125}}, read_reply->bytes())->pdu,
              Response{ReadHoldingRegistersResponse{words(125)}});
}

TEST(Encoding, DeviceIdentificationThatCannotFitIsRefused) {
    DeviceIdentificationResponse id;
    id.objects = {{0, std::string(200, 'x')}, {1, std::string(60, 'y')}};
    EXPECT_EQ(encode_response({1, id}).error(), ValidationError::AduTooLong);
    id.objects = {{0, std::string(256, 'x')}};
    EXPECT_EQ(encode_response({1, id}).error(), ValidationError::AduTooLong);
}

TEST(Encoding, ExceptionResponses) {
    for (const auto code :
         {ExceptionCode::IllegalFunction, ExceptionCode::IllegalDataAddress, ExceptionCode::IllegalDataValue,
          ExceptionCode::ServerDeviceFailure, ExceptionCode::Acknowledge, ExceptionCode::ServerDeviceBusy,
          ExceptionCode::MemoryParityError, ExceptionCode::GatewayPathUnavailable,
          ExceptionCode::GatewayTargetFailedToRespond}) {
        EXPECT_TRUE(is_defined(code));
        EXPECT_NE(to_string(code), "undefined exception code");
        const RequestAdu request{9, ReadHoldingRegisters{0x100, 4}};
        const auto adu = encode_response({9, ExceptionResponse{0x03, code}});
        ASSERT_TRUE(adu.has_value());
        EXPECT_EQ(adu->size(), 5U);
        EXPECT_EQ((*adu)[1], 0x83);
        EXPECT_EQ(reply_bytes_needed(request, adu->bytes().first(2)), 5U);
        const auto decoded = decode_response(request, adu->bytes());
        ASSERT_TRUE(decoded.has_value());
        EXPECT_EQ(std::get<ExceptionResponse>(decoded->pdu).code, code);
    }
    EXPECT_FALSE(is_defined(static_cast<ExceptionCode>(7)));
    EXPECT_EQ(encode_response({1, ExceptionResponse{0x83, ExceptionCode::IllegalFunction}}).error(),
              ValidationError::InvalidExceptionCode);
    EXPECT_EQ(encode_response({1, ExceptionResponse{0x03, static_cast<ExceptionCode>(0)}}).error(),
              ValidationError::InvalidExceptionCode);
}

TEST(Encoding, UndefinedExceptionCodesStillDecode) {
    const RequestAdu request{1, WriteSingleRegister{1, 2}};
    const auto decoded = decode_response(request, with_crc("01 86 42").bytes());
    ASSERT_TRUE(decoded.has_value());
    EXPECT_EQ(static_cast<int>(std::get<ExceptionResponse>(decoded->pdu).code), 0x42);
}

TEST(Encoding, RepliesNeedAUnicastAddress) {
    EXPECT_EQ(encode_response({0, WriteSingleRegisterResponse{1, 2}}).error(), ValidationError::InvalidSlaveAddress);
    EXPECT_EQ(encode_response({248, WriteSingleRegisterResponse{1, 2}}).error(), ValidationError::InvalidSlaveAddress);
}

TEST(ReplyDecoding, RejectsWhatIsNotTheReplyToTheRequest) {
    const RequestAdu read{5, ReadHoldingRegisters{0x10, 2}};
    EXPECT_EQ(decode_response(read, with_crc("06 03 04 00 01 00 02").bytes()).error(), DecodeError::UnexpectedSlave);
    EXPECT_EQ(decode_response(read, with_crc("05 06 00 10 00 01").bytes()).error(), DecodeError::UnexpectedFunction);
    EXPECT_EQ(decode_response(read, with_crc("05 86 02").bytes()).error(), DecodeError::UnexpectedFunction);
    EXPECT_EQ(decode_response(read, with_crc("05 03 02 00 01").bytes()).error(), DecodeError::ByteCountMismatch);
    EXPECT_EQ(decode_response(read, with_crc("05 03 04 00 01 00").bytes()).error(), DecodeError::LengthMismatch);
    EXPECT_EQ(decode_response(read, with_crc("05 83 02 00").bytes()).error(), DecodeError::LengthMismatch);
    EXPECT_EQ(decode_response(read, hex("05 03 04 00 01 00 02 00 00")).error(), DecodeError::CrcMismatch);
    EXPECT_EQ(decode_response(read, hex("05 03 04")).error(), DecodeError::TooShort);
    EXPECT_EQ(decode_response(read, std::vector<std::uint8_t>(257, 0)).error(), DecodeError::TooLong);

    EXPECT_EQ(decode_response({0, WriteSingleRegister{1, 2}}, with_crc("00 06 00 01 00 02").bytes()).error(),
              DecodeError::UnexpectedSlave);
    const RequestAdu write{5, WriteSingleRegister{0x10, 7}};
    EXPECT_EQ(decode_response(write, with_crc("05 06 00 10 00 08").bytes()).error(), DecodeError::EchoMismatch);
    EXPECT_EQ(decode_response(write, with_crc("05 06 00 11 00 07").bytes()).error(), DecodeError::EchoMismatch);
    const RequestAdu write_many{5, WriteMultipleRegisters{0x10, words(3)}};
    EXPECT_EQ(decode_response(write_many, with_crc("05 10 00 10 00 02").bytes()).error(), DecodeError::EchoMismatch);
    EXPECT_EQ(decode_response(write_many, with_crc("05 10 00 10 00 03 00").bytes()).error(),
              DecodeError::LengthMismatch);
}

TEST(ReplyDecoding, DeviceIdentificationFields) {
    const RequestAdu request{3, ReadDeviceIdentification{DeviceIdCode::Regular, 0}};
    // More follows, next object 0x05, two objects.
    const auto adu = with_crc("03 2B 0E 02 82 FF 05 02 03 02 41 42 04 00");
    const auto decoded = decode_response(request, adu.bytes());
    ASSERT_TRUE(decoded.has_value()) << to_string(decoded.error());
    const auto& id = std::get<DeviceIdentificationResponse>(decoded->pdu);
    EXPECT_EQ(id.code, DeviceIdCode::Regular);
    EXPECT_EQ(id.conformity, 0x82);
    EXPECT_TRUE(id.more_follows);
    EXPECT_EQ(id.next_object_id, 0x05);
    ASSERT_EQ(id.objects.size(), 2U);
    EXPECT_EQ(id.objects[0], (DeviceObject{0x03, "AB"}));
    EXPECT_EQ(id.objects[1], (DeviceObject{0x04, ""}));
    EXPECT_EQ(encode_response(*decoded).value(), adu);

    EXPECT_EQ(decode_response(request, with_crc("03 2B 0E 01 82 00 00 00").bytes()).error(), DecodeError::EchoMismatch);
    EXPECT_EQ(decode_response(request, with_crc("03 2B 0D 02 82 00 00 00").bytes()).error(),
              DecodeError::InvalidMeiType);
    EXPECT_EQ(decode_response(request, with_crc("03 2B 0E 02 82 00 00 01 00 05 41").bytes()).error(),
              DecodeError::ObjectOverrun);
    EXPECT_EQ(decode_response(request, with_crc("03 2B 0E 02 82 00 00 00 99").bytes()).error(),
              DecodeError::LengthMismatch);
    EXPECT_EQ(decode_response(request, with_crc("03 2B 0E 02").bytes()).error(), DecodeError::TooShort);
    EXPECT_EQ(decode_response(request, with_crc("03 2B 0E 02 82 01 00 00").bytes()).error(), DecodeError::InvalidField);
}

TEST(RequestDecoding, MapsProblemsToTheExceptionASlaveAnswers) {
    EXPECT_EQ(decode_request(with_crc("01 04 00 00 00 01").bytes()).error(), DecodeError::UnknownFunction);
    EXPECT_EQ(exception_for(DecodeError::UnknownFunction), ExceptionCode::IllegalFunction);
    EXPECT_EQ(decode_request(with_crc("01 2B 0D 01 00").bytes()).error(), DecodeError::InvalidMeiType);
    EXPECT_EQ(exception_for(DecodeError::InvalidMeiType), ExceptionCode::IllegalFunction);
    EXPECT_EQ(decode_request(with_crc("01 2B 0E 05 00").bytes()).error(), DecodeError::InvalidDeviceIdCode);
    EXPECT_EQ(exception_for(DecodeError::InvalidDeviceIdCode), ExceptionCode::IllegalDataValue);
    EXPECT_EQ(decode_request(with_crc("01 03 00 00 00 00").bytes()).error(), DecodeError::QuantityOutOfRange);
    EXPECT_EQ(decode_request(with_crc("01 03 00 00 00 7E").bytes()).error(), DecodeError::QuantityOutOfRange);
    EXPECT_EQ(decode_request(with_crc("01 10 00 00 00 7C F8").bytes()).error(), DecodeError::QuantityOutOfRange);
    EXPECT_EQ(exception_for(DecodeError::QuantityOutOfRange), ExceptionCode::IllegalDataValue);
    EXPECT_EQ(decode_request(with_crc("01 10 00 00 00 01 02 00").bytes()).error(), DecodeError::LengthMismatch);
    EXPECT_EQ(decode_request(with_crc("01 03 00 00 00").bytes()).error(), DecodeError::LengthMismatch);
    // Broken frames are ignored, not answered.
    EXPECT_EQ(decode_request(hex("01 03 00 00 00 01 00 00")).error(), DecodeError::CrcMismatch);
    EXPECT_EQ(exception_for(DecodeError::CrcMismatch), std::nullopt);
    EXPECT_EQ(decode_request(hex("01 03 00")).error(), DecodeError::TooShort);
    EXPECT_EQ(exception_for(DecodeError::TooShort), std::nullopt);
}

TEST(RequestDecoding, BroadcastWritesDecodeWithAddressZero) {
    const auto adu = encode_request({0, WriteMultipleRegisters{400, {1, 2}}});
    ASSERT_TRUE(adu.has_value());
    const auto decoded = decode_request(adu->bytes());
    ASSERT_TRUE(decoded.has_value());
    EXPECT_EQ(decoded->address, kBroadcastAddress);
    EXPECT_EQ(expected_reply_length(*decoded).kind, ReplyLength::Kind::None);
}

TEST(ReplyLengths, ForEveryRequestTheMasterCanSend) {
    EXPECT_EQ(expected_reply_length({1, ReadHoldingRegisters{0, 1}}).length, 7U);
    EXPECT_EQ(expected_reply_length({1, ReadHoldingRegisters{0, 125}}).length, 255U);
    EXPECT_EQ(expected_reply_length({1, WriteSingleRegister{0, 1}}).length, 8U);
    EXPECT_EQ(expected_reply_length({1, WriteMultipleRegisters{0, words(123)}}).length, 8U);
    const auto id = expected_reply_length({1, ReadDeviceIdentification{}});
    EXPECT_EQ(id.kind, ReplyLength::Kind::Variable);
    EXPECT_EQ(id.length, 10U);
    EXPECT_EQ(id.max_length, 256U);
    EXPECT_EQ(expected_reply_length({0, WriteSingleRegister{0, 1}}).kind, ReplyLength::Kind::None);
    EXPECT_EQ(ReplyLength::kException, 5U);
}

TEST(ReplyLengths, NeededBytesGrowAsTheDeviceIdentificationArrives) {
    const RequestAdu request{3, ReadDeviceIdentification{DeviceIdCode::Regular, 0}};
    const auto adu = with_crc("03 2B 0E 02 82 00 00 02 03 02 41 42 04 01 43");
    const auto bytes = adu.bytes();
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(0)), 2U);
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(1)), 2U);
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(2)), 8U);
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(7)), 8U);
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(8)), 10U);   // first object header
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(10)), 14U);  // second object header
    EXPECT_EQ(reply_bytes_needed(request, bytes.first(14)), 17U);  // + "C" + CRC
    EXPECT_EQ(reply_bytes_needed(request, bytes), bytes.size());
    // Object lengths that could never fit in 256 bytes: framed by silence instead.
    EXPECT_EQ(reply_bytes_needed(request, hex("03 2B 0E 02 82 00 00 02 03 FF 41")), 0U);
}

TEST(ReplyLengths, NotAReplyToThisRequest) {
    const RequestAdu request{3, ReadHoldingRegisters{0, 2}};
    EXPECT_EQ(reply_bytes_needed(request, hex("04")), 0U);
    EXPECT_EQ(reply_bytes_needed(request, hex("03 06")), 0U);
    EXPECT_EQ(reply_bytes_needed(request, hex("03 03")), 9U);
    EXPECT_EQ(reply_bytes_needed({0, WriteSingleRegister{1, 1}}, hex("00 06")), 0U);
}

TEST(Adu, RefusesToGrowPast256Bytes) {
    Adu adu;
    for (std::size_t i = 0; i < kMaxAduSize; ++i) {
        ASSERT_TRUE(adu.push_back(0x55));
    }
    EXPECT_TRUE(adu.full());
    EXPECT_FALSE(adu.push_back(0x55));
    EXPECT_FALSE(adu.append_u16(0x1234));
    EXPECT_FALSE(adu.append_crc());
    EXPECT_EQ(adu.size(), kMaxAduSize);
}

}  // namespace
}  // namespace drivebus::rtu
