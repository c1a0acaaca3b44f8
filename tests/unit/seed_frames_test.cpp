// SPDX-License-Identifier: Apache-2.0
// Every example frame printed in the Altivar 21 Modbus guide and the Altivar 58 RS485 manual,
// encoded and decoded from both ends of the line, with its CRC checked. Frames whose printed
// CRC is wrong are errata (docs/errata.md): the tests pin the correct value and show the
// printed one fails.
#include <gtest/gtest.h>

#include "drive_limits.hpp"
#include "hex.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"

namespace drivebus::rtu {
namespace {

using test::atv21_limits;
using test::atv58_limits;
using test::hex;
using test::to_hex;

// The request encodes to exactly the printed bytes, and a slave decodes them back.
void expect_request(const RequestAdu& request, const char* printed, const FunctionLimits& limits) {
    const auto bytes = hex(printed);
    ASSERT_TRUE(crc_ok(bytes)) << printed;
    const auto encoded = encode_request(request, limits);
    ASSERT_TRUE(encoded.has_value()) << to_string(encoded.error());
    EXPECT_EQ(to_hex(encoded->bytes()), to_hex(bytes));
    const auto decoded = decode_request(bytes);
    ASSERT_TRUE(decoded.has_value()) << to_string(decoded.error());
    EXPECT_EQ(*decoded, request);
}

// The reply encodes to exactly the printed bytes, and the master decodes them back.
void expect_reply(const RequestAdu& request, const ResponseAdu& reply, const char* printed) {
    const auto bytes = hex(printed);
    ASSERT_TRUE(crc_ok(bytes)) << printed;
    const auto encoded = encode_response(reply);
    ASSERT_TRUE(encoded.has_value()) << to_string(encoded.error());
    EXPECT_EQ(to_hex(encoded->bytes()), to_hex(bytes));
    const auto decoded = decode_response(request, bytes);
    ASSERT_TRUE(decoded.has_value()) << to_string(decoded.error());
    EXPECT_EQ(*decoded, reply);
    EXPECT_EQ(reply_bytes_needed(request, bytes), bytes.size());
}

ResponseAdu exception(std::uint8_t function, ExceptionCode code) {
    return {1, ExceptionResponse{function, code}};
}

// ---- Altivar 21 guide, 7.4: Read one word (FC03, quantity 1) ----

TEST(Atv21Seed, ReadOutputFrequencyFD00) {
    const RequestAdu request{1, ReadHoldingRegisters{0xFD00, 1}};
    expect_request(request, "01 03 FD 00 00 01 B5 A6", atv21_limits());
    // 0x1770 = 6000 = 60.00 Hz in units of 0.01 Hz.
    expect_reply(request, {1, ReadHoldingRegistersResponse{{0x1770}}}, "01 03 02 17 70 B6 50");
    EXPECT_EQ(expected_reply_length(request).length, 7U);
}

TEST(Atv21Seed, ReadingTwoPlainWordsIsRefused) {
    const RequestAdu request{1, ReadHoldingRegisters{0xFD00, 2}};
    // The frame is valid Modbus; the drive answers exception 3, and the master's validation
    // with the drive's limits keeps it off the wire.
    expect_request(request, "01 03 FD 00 00 02 F5 A7", FunctionLimits::modbus_spec());
    EXPECT_EQ(encode_request(request, atv21_limits()).error(), ValidationError::QuantityAboveDriveLimit);
    expect_reply(request, exception(0x03, ExceptionCode::IllegalDataValue), "01 83 03 01 31");
}

// ---- 7.5: Read indirect block (FC03 at 0x1875, quantity 2-5) ----

TEST(Atv21Seed, ReadIndirectBlockOfFive) {
    const RequestAdu request{1, ReadHoldingRegisters{0x1875, 5}};
    expect_request(request, "01 03 18 75 00 05 92 B3", atv21_limits());
    // F875-F879 select FD01, FD00, FE03, FE05, FC91.
    expect_reply(request, {1, ReadHoldingRegistersResponse{{0x6404, 0x1770, 0x0000, 0x26FB, 0x0080}}},
                 "01 03 0A 64 04 17 70 00 00 26 FB 00 80 1E 29");
}

TEST(Atv21Seed, ReadIndirectBlockOfTwo) {
    const RequestAdu request{1, ReadHoldingRegisters{0x1875, 2}};
    expect_request(request, "01 03 18 75 00 02 D3 71", atv21_limits());
    expect_reply(request, {1, ReadHoldingRegistersResponse{{0x6404, 0x1770}}}, "01 03 04 64 04 17 70 AA D6");
}

TEST(Atv21Seed, IndirectBlockAtWrongStartIsRefused) {
    const RequestAdu request{1, ReadHoldingRegisters{0x1876, 2}};
    expect_request(request, "01 03 18 76 00 02 23 71", FunctionLimits::modbus_spec());
    EXPECT_EQ(encode_request(request, atv21_limits()).error(), ValidationError::QuantityAboveDriveLimit);
    expect_reply(request, exception(0x03, ExceptionCode::IllegalDataValue), "01 83 03 01 31");
}

TEST(Atv21Seed, IndirectBlockOfSixIsRefused) {
    const RequestAdu request{1, ReadHoldingRegisters{0x1875, 6}};
    expect_request(request, "01 03 18 75 00 06 D2 B2", FunctionLimits::modbus_spec());
    EXPECT_EQ(encode_request(request, atv21_limits()).error(), ValidationError::QuantityAboveDriveLimit);
    expect_reply(request, exception(0x03, ExceptionCode::IllegalDataValue), "01 83 03 01 31");
}

// ---- 7.6: Write Single Register (FC06) ----

TEST(Atv21Seed, WriteFrequencyReference60Hz) {
    const RequestAdu request{1, WriteSingleRegister{0xFA01, 0x1770}};
    expect_request(request, "01 06 FA 01 17 70 E6 C6", atv21_limits());
    expect_reply(request, {1, WriteSingleRegisterResponse{0xFA01, 0x1770}}, "01 06 FA 01 17 70 E6 C6");
}

TEST(Atv21Seed, WriteToUnknownRegisterGetsException2) {
    const RequestAdu request{1, WriteSingleRegister{0xFFFF, 0x0000}};
    expect_request(request, "01 06 FF FF 00 00 89 EE", atv21_limits());
    expect_reply(request, exception(0x06, ExceptionCode::IllegalDataAddress), "01 86 02 C3 A1");
}

// ---- 7.7: Write one word (FC16, quantity 1) ----

TEST(Atv21Seed, WriteOneWordWithFunction16) {
    const RequestAdu request{1, WriteMultipleRegisters{0xFA01, {0x1770}}};
    expect_request(request, "01 10 FA 01 00 01 02 17 70 F3 9A", atv21_limits());
    expect_reply(request, {1, WriteMultipleRegistersResponse{0xFA01, 1}}, "01 10 FA 01 00 01 60 D1");
}

// ---- 7.8: Write indirect block (FC16 at 0x1870, quantity 2) ----

const RequestAdu kWriteBlock{1, WriteMultipleRegisters{0x1870, {0xC400, 0x1770}}};

TEST(Atv21Seed, WriteIndirectBlockRequest) {
    // F870 = FA00 (command word 0xC400), F871 = FA01 (60.00 Hz).
    expect_request(kWriteBlock, "01 10 18 70 00 02 04 C4 00 17 70 6D AF", atv21_limits());
}

TEST(Atv21Seed, ErratumWriteIndirectBlockReplyCrc) {
    // Printed as 01 10 18 70 00 02 43 B3; its CRC does not check out.
    EXPECT_FALSE(crc_ok(hex("01 10 18 70 00 02 43 B3")));
    EXPECT_EQ(decode_response(kWriteBlock, hex("01 10 18 70 00 02 43 B3")).error(), DecodeError::CrcMismatch);
    EXPECT_EQ(crc16(hex("01 10 18 70 00 02")), 0xB346);
    expect_reply(kWriteBlock, {1, WriteMultipleRegistersResponse{0x1870, 2}}, "01 10 18 70 00 02 46 B3");
}

TEST(Atv21Seed, WriteIndirectBlockBusyOrUnconfigured) {
    // F870 = 0 (or the drive is busy): exception 4.
    expect_reply(kWriteBlock, exception(0x10, ExceptionCode::ServerDeviceFailure), "01 90 04 4D C3");
}

TEST(Atv21Seed, WriteIndirectBlockAtWrongStart) {
    const RequestAdu request{1, WriteMultipleRegisters{0x1871, {0xC400, 0x1770}}};
    expect_request(request, "01 10 18 71 00 02 04 C4 00 17 70 AC 63", FunctionLimits::modbus_spec());
    EXPECT_EQ(encode_request(request, atv21_limits()).error(), ValidationError::QuantityAboveDriveLimit);
    expect_reply(request, exception(0x10, ExceptionCode::IllegalDataValue), "01 90 03 0C 01");
}

TEST(Atv21Seed, WriteIndirectBlockWithWrongQuantity) {
    // Quantity 3 with byte count 4: no encoder makes this; the slave answers exception 3.
    const auto bytes = hex("01 10 18 70 00 03 04 C4 00 17 70 6C 7E");
    ASSERT_TRUE(crc_ok(bytes));
    const auto decoded = decode_request(bytes);
    ASSERT_FALSE(decoded.has_value());
    EXPECT_EQ(decoded.error(), DecodeError::ByteCountMismatch);
    EXPECT_EQ(exception_for(decoded.error()), ExceptionCode::IllegalDataValue);
    expect_reply(kWriteBlock, exception(0x10, ExceptionCode::IllegalDataValue), "01 90 03 0C 01");
}

TEST(Atv21Seed, WriteIndirectBlockWithWrongByteCount) {
    const auto bytes = hex("01 10 18 70 00 02 03 C4 00 17 70 D8 6F");
    ASSERT_TRUE(crc_ok(bytes));
    const auto decoded = decode_request(bytes);
    ASSERT_FALSE(decoded.has_value());
    EXPECT_EQ(decoded.error(), DecodeError::ByteCountMismatch);
    EXPECT_EQ(exception_for(decoded.error()), ExceptionCode::IllegalDataValue);
}

// ---- 8.5: Frequency reference 80 Hz ----

TEST(Atv21Seed, ErratumFrequencyReference80HzCrc) {
    // Printed as 01 06 FA 01 1F 40 B5 A6 (request and reply): B5 A6 is the CRC of the FD00
    // read frame of 7.4, not of this one.
    EXPECT_FALSE(crc_ok(hex("01 06 FA 01 1F 40 B5 A6")));
    EXPECT_EQ(crc16(hex("01 03 FD 00 00 01")), 0xA6B5);
    EXPECT_EQ(crc16(hex("01 06 FA 01 1F 40")), 0x12E1);
    const RequestAdu request{1, WriteSingleRegister{0xFA01, 8000}};  // 80 Hz / 0.01 Hz
    expect_request(request, "01 06 FA 01 1F 40 E1 12", atv21_limits());
    expect_reply(request, {1, WriteSingleRegisterResponse{0xFA01, 0x1F40}}, "01 06 FA 01 1F 40 E1 12");
}

// ---- 7.9: Read Device Identification (FC43/14) ----

TEST(Atv21Seed, DeviceIdentificationRequest) {
    for (const DeviceIdCode code : {DeviceIdCode::Basic, DeviceIdCode::Regular, DeviceIdCode::Extended}) {
        const RequestAdu request{1, ReadDeviceIdentification{code, 0x00}};
        const auto adu = encode_request(request, atv21_limits());
        ASSERT_TRUE(adu.has_value());
        ASSERT_EQ(adu->size(), 7U);
        EXPECT_EQ(to_hex(adu->bytes().first(5)), "01 2B 0E 0" + std::to_string(static_cast<int>(code)) + " 00");
        EXPECT_EQ(decode_request(adu->bytes()).value(), request);
    }
}

DeviceIdentificationResponse guide_identification(std::string vendor) {
    DeviceIdentificationResponse id;
    id.code = DeviceIdCode::Basic;
    id.conformity = 0x01;
    id.objects = {{0x00, std::move(vendor)}, {0x01, "ATV21H075M3X"}, {0x02, "0201"}};
    return id;
}

TEST(Atv21Seed, DeviceIdentificationReplyLengthsComeFromTheStrings) {
    const RequestAdu request{1, ReadDeviceIdentification{DeviceIdCode::Basic, 0}};
    const ResponseAdu reply{1, guide_identification("Schneider Electric")};
    const auto adu = encode_response(reply);
    ASSERT_TRUE(adu.has_value());
    // Header as printed: 2B 0E 01 01 (conformity), more follows 00, next object 00, 3 objects.
    EXPECT_EQ(to_hex(adu->bytes().first(8)), "01 2B 0E 01 01 00 00 03");
    EXPECT_EQ((*adu)[8], 0x00);
    EXPECT_EQ((*adu)[9], 18);  // "Schneider Electric": 18 bytes, not the printed 0x0D
    EXPECT_EQ((*adu)[28], 0x01);
    EXPECT_EQ((*adu)[29], 0x0C);  // "ATV21H075M3X": 12 bytes, as printed (the text says 11)
    EXPECT_EQ((*adu)[42], 0x02);
    EXPECT_EQ((*adu)[43], 0x04);
    EXPECT_EQ(adu->size(), 50U);
    EXPECT_EQ(reply_bytes_needed(request, adu->bytes()), 50U);
    EXPECT_EQ(decode_response(request, adu->bytes()).value(), reply);
}

TEST(Atv21Seed, ErratumDeviceIdentificationVendorLength) {
    // The guide prints object 0 with length 0x0D (13) and says the reply is 45 bytes, but
    // names "Schneider Electric" (18 bytes). 45 bytes is exactly the reply with a 13-byte
    // vendor name; with the printed name it is 50. The frame as printed (0x0D followed by the
    // 18-byte name) does not decode.
    const RequestAdu request{1, ReadDeviceIdentification{DeviceIdCode::Basic, 0}};
    const auto thirteen = encode_response({1, guide_identification("Telemecanique")});
    ASSERT_TRUE(thirteen.has_value());
    EXPECT_EQ((*thirteen)[9], 0x0D);
    EXPECT_EQ(thirteen->size(), 45U);

    Adu printed;
    ASSERT_TRUE(printed.append(hex("01 2B 0E 01 01 00 00 03 00 0D")));
    const std::string vendor = "Schneider Electric";
    for (const char ch : vendor) {
        ASSERT_TRUE(printed.push_back(static_cast<std::uint8_t>(ch)));
    }
    ASSERT_TRUE(printed.append(hex("01 0C")));
    for (const char ch : std::string("ATV21H075M3X")) {
        ASSERT_TRUE(printed.push_back(static_cast<std::uint8_t>(ch)));
    }
    ASSERT_TRUE(printed.append(hex("02 04 30 32 30 31")));
    ASSERT_TRUE(printed.append_crc());
    EXPECT_FALSE(decode_response(request, printed.bytes()).has_value());
}

// ---- Altivar 58 RS485 manual: functions 03 and 16 ----

TEST(Atv58Seed, ReadSupervisionWordsW450ToW459) {
    // Printed as "02 03 01C2 000A CRC16": W450 is register 450 = 0x01C2.
    const RequestAdu request{2, ReadHoldingRegisters{450, 10}};
    expect_request(request, "02 03 01 C2 00 0A 65 FE", atv58_limits());
    // Reply "02 03 14 xxxx ... CRC16": byte count 0x14 = 20 for ten words, 25 bytes in all.
    EXPECT_EQ(expected_reply_length(request).length, 25U);
    ReadHoldingRegistersResponse words;
    for (std::uint16_t i = 0; i < 10; ++i) {
        words.values.push_back(static_cast<std::uint16_t>(0x1000 + i));
    }
    const auto reply = encode_response({2, words});
    ASSERT_TRUE(reply.has_value());
    EXPECT_EQ(to_hex(reply->bytes().first(3)), "02 03 14");
    EXPECT_EQ(decode_response(request, reply->bytes())->pdu, Response{words});
}

TEST(Atv58Seed, WriteCommandAndSetpointW400W401) {
    // "02 10 0190 0002 04 000F 0190 CRC16": 15 to W400, 400 to W401.
    const RequestAdu request{2, WriteMultipleRegisters{400, {15, 400}}};
    expect_request(request, "02 10 01 90 00 02 04 00 0F 01 90 C9 E8", atv58_limits());
    expect_reply(request, {2, WriteMultipleRegistersResponse{400, 2}}, "02 10 01 90 00 02 40 2A");
}

TEST(Atv58Seed, ManualLimitsAreEnforced) {
    EXPECT_TRUE(encode_request({31, ReadHoldingRegisters{450, 32}}, atv58_limits()).has_value());
    EXPECT_EQ(encode_request({2, ReadHoldingRegisters{450, 33}}, atv58_limits()).error(),
              ValidationError::QuantityAboveDriveLimit);
    RegisterValues thirty;
    RegisterValues thirty_one;
    for (int i = 0; i < 31; ++i) {
        if (i < 30) {
            thirty.push_back(0);
        }
        thirty_one.push_back(0);
    }
    EXPECT_TRUE(encode_request({2, WriteMultipleRegisters{400, thirty}}, atv58_limits()).has_value());
    EXPECT_EQ(encode_request({2, WriteMultipleRegisters{400, thirty_one}}, atv58_limits()).error(),
              ValidationError::QuantityAboveDriveLimit);
    EXPECT_EQ(encode_request({32, ReadHoldingRegisters{450, 1}}, atv58_limits()).error(),
              ValidationError::InvalidSlaveAddress);
    EXPECT_EQ(encode_request({2, ReadDeviceIdentification{}}, atv58_limits()).error(),
              ValidationError::FunctionNotSupported);
    // Broadcast: 06 and 16 only.
    EXPECT_TRUE(encode_request({0, WriteSingleRegister{400, 0}}, atv58_limits()).has_value());
    EXPECT_TRUE(encode_request({0, WriteMultipleRegisters{400, {0, 0}}}, atv58_limits()).has_value());
    EXPECT_EQ(encode_request({0, ReadHoldingRegisters{450, 1}}, atv58_limits()).error(),
              ValidationError::BroadcastNotAllowed);
}

}  // namespace
}  // namespace drivebus::rtu
