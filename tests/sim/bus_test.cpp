// SPDX-License-Identifier: Apache-2.0
// The line logic: which frames get replies, when the reply's bytes are due, and each fault.
#include <gtest/gtest.h>

#include "hex.hpp"
#include "rtu/crc.hpp"
#include "sim_fixture.hpp"

namespace drivebus::sim {
namespace {

using drivebus::test::hex;
using drivebus::test::to_hex;
using namespace std::chrono_literals;

const rtu::CharacterTiming kTiming = rtu::character_timing({19200, 8, rtu::Parity::None, 1}).value();

class BusTest : public ::testing::Test {
protected:
    Bus bus{{kTiming, 1ms, true, 7}};

    void SetUp() override {
        bus.add(make_drive(1, test::profile("atv21")));
        bus.add(make_drive(2, test::profile("atv58")));
    }

    // A frame whose last character ended at `last`.
    static rtu::Frame frame(const std::vector<std::uint8_t>& bytes, rtu::Instant last = test::at(0)) {
        rtu::Frame f;
        f.adu.append(bytes);
        f.last = last;
        f.first = last - kTiming.character * static_cast<std::int64_t>(bytes.size() - 1);
        return f;
    }
    // A valid W450-W459 read (ATV58 limits) or FD00 read, addressed to `address`.
    static std::vector<std::uint8_t> encode(rtu::SlaveAddress address) {
        const rtu::Request pdu = address == 2 ? rtu::Request{rtu::ReadHoldingRegisters{450, 10}}
                                              : rtu::Request{rtu::ReadHoldingRegisters{0xFD00, 1}};
        const auto adu = rtu::encode_request({address, pdu}).value();
        return {adu.bytes().begin(), adu.bytes().end()};
    }
    static std::string bytes_of(const TxPlan& plan) {
        std::vector<std::uint8_t> b;
        for (const auto& x : plan) {
            b.push_back(x.value);
        }
        return to_hex(b);
    }
};

TEST_F(BusTest, ReplyIsPacedAfterTheSilenceAndTurnaround) {
    const auto plan = bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")));
    ASSERT_EQ(plan.size(), 7U);
    // The drive sees the end of the request t3.5 after its last character, answers 1 ms
    // later, and each character reaches the master one character time after the previous.
    const rtu::Instant start = test::at(0) + kTiming.t3_5 + 1ms;
    for (std::size_t i = 0; i < plan.size(); ++i) {
        EXPECT_EQ(plan[i].at, start + kTiming.character * static_cast<std::int64_t>(i + 1)) << i;
    }
    EXPECT_EQ(bytes_of(plan), "01 03 02 00 00 B8 44");
    EXPECT_EQ(bus.counters().requests, 1U);
    EXPECT_EQ(bus.counters().replies, 1U);
}

TEST_F(BusTest, UnpacedRepliesGoOutTogether) {
    Bus unpaced{{kTiming, 1ms, false, 7}};
    unpaced.add(make_drive(1, test::profile("atv21")));
    const auto plan = unpaced.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")));
    ASSERT_EQ(plan.size(), 7U);
    EXPECT_EQ(plan.front().at, plan.back().at);
}

TEST_F(BusTest, OtherAddressesAndBroadcastsGetNoReply) {
    EXPECT_TRUE(bus.on_frame(frame(encode(5))).empty());
    EXPECT_EQ(bus.counters().foreign, 1U);
    // Broadcast FC06: both drives obey, nobody answers.
    const auto broadcast = rtu::encode_request({0, rtu::WriteSingleRegister{0xFA01, 1234}}).value();
    EXPECT_TRUE(bus.on_frame(frame({broadcast.bytes().begin(), broadcast.bytes().end()})).empty());
    EXPECT_EQ(bus.counters().broadcasts, 1U);
    EXPECT_EQ(bus.drive(1)->peek("FA01").value(), 1234);
}

TEST_F(BusTest, MalformedRequestsGetTheSpecException) {
    // Guide 7.8: byte count 3 for two words -> exception 3.
    const auto plan = bus.on_frame(frame(hex("01 10 18 70 00 02 03 C4 00 17 70 D8 6F")));
    EXPECT_EQ(bytes_of(plan), "01 90 03 0C 01");
    // An unknown function -> exception 1.
    rtu::Adu fc04;
    fc04.append(hex("01 04 00 00 00 01"));
    fc04.append_crc();
    const auto plan2 = bus.on_frame(frame({fc04.bytes().begin(), fc04.bytes().end()}));
    ASSERT_EQ(plan2.size(), 5U);
    EXPECT_EQ(plan2[1].value, 0x84);
    EXPECT_EQ(plan2[2].value, 0x01);
}

// Function 0 has no exception reply (0x80 alone names no function): the frame is
// counted as broken and gets no reply (found by fuzz_sim_frames: the reply was used unbuilt).
TEST_F(BusTest, FunctionZeroGetsNoReply) {
    rtu::Adu fc00;
    fc00.append(hex("01 00 06 01 03 FD"));
    fc00.append_crc();
    EXPECT_TRUE(bus.on_frame(frame({fc00.bytes().begin(), fc00.bytes().end()})).empty());
    EXPECT_EQ(bus.counters().broken, 1U);
    EXPECT_EQ(bus.counters().requests, 0U);
}

TEST_F(BusTest, CrcFault) {
    ASSERT_TRUE(bus.faults().apply(1, "crc=1").has_value());
    const auto plan = bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")));
    std::vector<std::uint8_t> bytes;
    for (const auto& b : plan) {
        bytes.push_back(b.value);
    }
    EXPECT_FALSE(rtu::crc_ok(bytes));
    EXPECT_EQ(bus.counters().crc, 1U);
    // Drive 2 has no fault of its own and the line default is clean.
    EXPECT_EQ(bus.on_frame(frame(encode(2))).size(), 25U);
}

TEST_F(BusTest, DropFaultOnlyForItsDrive) {
    ASSERT_TRUE(bus.faults().apply(2, "drop=1").has_value());
    EXPECT_TRUE(bus.on_frame(frame(encode(2))).empty());
    EXPECT_EQ(bus.counters().dropped, 1U);
    EXPECT_FALSE(bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6"))).empty());
}

TEST_F(BusTest, ShareOfFaultsIsAShare) {
    ASSERT_TRUE(bus.faults().apply(0, "drop=0.5").has_value());
    int answered = 0;
    for (int i = 0; i < 400; ++i) {
        answered += bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6"), test::at(i))).empty() ? 0 : 1;
    }
    EXPECT_GT(answered, 120);
    EXPECT_LT(answered, 280);
    EXPECT_EQ(bus.counters().dropped, 400U - static_cast<unsigned>(answered));
}

TEST_F(BusTest, LateFault) {
    ASSERT_TRUE(bus.faults().apply(1, "late=50ms").has_value());
    const auto plan = bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")));
    EXPECT_EQ(plan.front().at, test::at(0) + kTiming.t3_5 + 1ms + 50ms + kTiming.character);
    EXPECT_EQ(bus.counters().late, 1U);
}

TEST_F(BusTest, GapFault) {
    ASSERT_TRUE(bus.faults().apply(1, "gap=3:2.5").has_value());
    const auto plan = bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")));
    ASSERT_EQ(plan.size(), 7U);
    EXPECT_EQ(plan[1].at - plan[0].at, kTiming.character);
    EXPECT_EQ(plan[3].at - plan[2].at, kTiming.character + kTiming.character * 5 / 2);
    EXPECT_EQ(bus.counters().gap, 1U);
}

TEST_F(BusTest, NoiseFault) {
    ASSERT_TRUE(bus.faults().apply(1, "noise=3:4").has_value());
    const auto plan = bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")));
    ASSERT_EQ(plan.size(), 10U);
    EXPECT_EQ(plan[3].at - plan[2].at, kTiming.character * 5);  // 4 characters of silence
    EXPECT_EQ(plan[3].value, 0x01);
    EXPECT_EQ(bus.counters().noise, 1U);
}

TEST_F(BusTest, ExceptionFault) {
    ASSERT_TRUE(bus.faults().apply(1, "exception=6").has_value());
    EXPECT_EQ(bytes_of(bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6")))), "01 83 06 C1 32");
    EXPECT_EQ(bus.counters().injected_exceptions, 1U);
    ASSERT_TRUE(bus.faults().apply(1, "exception=off").has_value());
    EXPECT_EQ(bus.on_frame(frame(hex("01 03 FD 00 00 01 B5 A6"))).size(), 7U);
}

TEST_F(BusTest, EchoFault) {
    const auto request = hex("01 03 FD 00 00 01 B5 A6");
    EXPECT_TRUE(bus.on_received(request, test::at(0)).empty());
    ASSERT_TRUE(bus.faults().apply(0, "echo=1").has_value());
    const auto echo = bus.on_received(request, test::at(0));
    EXPECT_EQ(bytes_of(echo), to_hex(request));
    EXPECT_EQ(echo.back().at, test::at(0));
    EXPECT_EQ(echo.front().at, test::at(0) - kTiming.character * 7);
    EXPECT_EQ(bus.counters().echoed, 8U);
}

TEST_F(BusTest, FaultSettingsRejectBadInputAndKeepTheOldOnes) {
    FaultTable& f = bus.faults();
    ASSERT_TRUE(f.apply(1, "crc=0.5").has_value());
    EXPECT_FALSE(f.apply(1, "crc=2").has_value());
    EXPECT_FALSE(f.apply(1, "crc=abc").has_value());
    EXPECT_FALSE(f.apply(1, "bogus=1").has_value());
    EXPECT_FALSE(f.apply(1, "late=forever").has_value());
    EXPECT_FALSE(f.apply(1, "gap=3").has_value());
    EXPECT_FALSE(f.apply(1, "noise=999").has_value());
    EXPECT_FALSE(f.apply(1, "exception=0x").has_value());
    EXPECT_FALSE(f.apply(1, "crc").has_value());
    EXPECT_EQ(f.for_drive(1).crc, 0.5);
    f.clear(std::nullopt);
    EXPECT_EQ(f.for_drive(1), DriveFaults{});
}

TEST(Durations, Parse) {
    EXPECT_EQ(option_duration("250us").value(), 250us);
    EXPECT_EQ(option_duration("2ms").value(), 2ms);
    EXPECT_EQ(option_duration("1.5s").value(), 1500ms);
    EXPECT_EQ(option_duration("0ms").value(), 0ms);
    EXPECT_NE(option_duration("3").error().find("'3' has no unit"), std::string::npos);
    EXPECT_FALSE(option_duration("ms").has_value());
    EXPECT_FALSE(option_duration("-1ms").has_value());
    EXPECT_FALSE(option_duration("2h").has_value());
    EXPECT_NE(option_duration("61min").error().find("above 1 hour"), std::string::npos);
}

}  // namespace
}  // namespace drivebus::sim
