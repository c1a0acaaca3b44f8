// SPDX-License-Identifier: Apache-2.0
// The Altivar 21 model against the guide's worked examples and its documented behaviour.
#include <gtest/gtest.h>

#include "atv21.hpp"
#include "sim_fixture.hpp"

namespace drivebus::sim {
namespace {

using rtu::ExceptionCode;
using test::ask;
using test::at;
using test::exception_of;
using test::read_one;

constexpr std::uint16_t kRunForwardWithPriority = 0xC400;  // guide 8.4: 0xC400 forward run
constexpr std::uint16_t kRunReverseWithPriority = 0xC600;

class Atv21 : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> profile = test::profile("atv21");
    Atv21Drive drive{1, profile};

    // Most tests leave long silences between requests: the Modbus time-out (F803, 3 s from
    // the factory) is off unless a test is about it.
    void SetUp() override { write(0x0803, 0, 0.0); }

    void write(std::uint16_t address, std::uint16_t value, double t) {
        const auto reply = ask(drive, rtu::WriteSingleRegister{address, value}, at(t));
        ASSERT_FALSE(exception_of(reply).has_value()) << "write 0x" << std::hex << address;
    }
};

TEST_F(Atv21, ReadOneWordAndRefuseTwo) {
    write(0xFA01, 6000, 0.0);
    EXPECT_EQ(read_one(drive, 0xFA01, at(0.1)), 6000);
    // Guide 7.4: two words at FD00 -> exception 3.
    EXPECT_EQ(exception_of(ask(drive, rtu::ReadHoldingRegisters{0xFD00, 2}, at(0.2))), ExceptionCode::IllegalDataValue);
}

TEST_F(Atv21, ReadIndirectBlockFollowsTheSelectors) {
    // Guide 7.5: F875-F879 = FD01, FD00, FE03, FE05, FC91.
    for (std::uint16_t i = 0; i < 5; ++i) {
        write(static_cast<std::uint16_t>(0x0875 + i), static_cast<std::uint16_t>(i + 1), 0.0);
    }
    // In effect after a reset (section 6): switched off and on.
    drive.power_cycle(at(0.0));
    write(0x0803, 0, 0.0);
    write(0xFA01, 6000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    const auto t = at(20.0);
    const auto reply = ask(drive, rtu::ReadHoldingRegisters{0x1875, 5}, t);
    const auto* words = std::get_if<rtu::ReadHoldingRegistersResponse>(&reply);
    ASSERT_NE(words, nullptr);
    ASSERT_EQ(words->values.size(), 5U);
    EXPECT_EQ(words->values[0], read_one(drive, 0xFD01, t));
    EXPECT_EQ(words->values[1], 6000);  // FD00: at speed
    EXPECT_EQ(words->values[2], read_one(drive, 0xFE03, t));
    EXPECT_EQ(words->values[3], read_one(drive, 0xFE05, t));
    EXPECT_EQ(words->values[4], read_one(drive, 0xFC91, t));
    // Two words: the first two selections.
    const auto two = ask(drive, rtu::ReadHoldingRegisters{0x1875, 2}, t);
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(two).values[1], 6000);
}

// Section 6: F870-F879 are "Après réinitialisation": written, they read back at once, but
// the blocks keep their selection until the drive is powered up again or reset after a fault.
TEST_F(Atv21, BlockSelectorsTakeEffectOnlyAfterAResetOrAPowerCycle) {
    write(0xFA01, 3000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    write(0x0875, 2, 0.0);  // FD00
    write(0x0876, 1, 0.0);  // FD01
    write(0x0870, 3, 0.0);  // FA01
    write(0x0871, 1, 0.0);  // FA00
    EXPECT_EQ(read_one(drive, 0x0875, at(1.0)), 2);
    const rtu::ReadHoldingRegisters read_block{0x1875, 2};
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(ask(drive, read_block, at(10.0))).values,
              (rtu::RegisterValues{0, 0}));
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteMultipleRegisters{0x1870, {2000, 0xC400}}, at(10.0))),
              ExceptionCode::ServerDeviceFailure);  // F870 = 0 still
    // A reset after a fault applies them.
    write(0xFA00, kRunForwardWithPriority | (1U << 12), 10.0);  // emergency stop: fault E
    write(0xFA00, 0xC000 | (1U << 13), 11.0);                   // fault reset
    write(0xFA00, kRunForwardWithPriority, 11.0);
    const auto after_reset = std::get<rtu::ReadHoldingRegistersResponse>(ask(drive, read_block, at(20.0))).values;
    EXPECT_EQ(after_reset[0], read_one(drive, 0xFD00, at(20.0)));
    EXPECT_EQ(after_reset[1], read_one(drive, 0xFD01, at(20.0)));
    EXPECT_GT(after_reset[0], 0);
    // A fault reset bit with no fault is no reset: a later change waits.
    write(0x0875, 1, 20.0);
    write(0xFA00, 0xC000 | (1U << 13), 20.0);
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(ask(drive, read_block, at(20.0))).values[0],
              read_one(drive, 0xFD00, at(20.0)));
    // Switched off and on: RAM parameters (section 8.2) start over, the selectors apply.
    drive.power_cycle(at(21.0));
    write(0x0803, 0, 21.0);
    EXPECT_EQ(read_one(drive, 0xFA00, at(21.0)), 0);
    EXPECT_EQ(read_one(drive, 0xFA01, at(21.0)), 0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(21.0)), 0);
    const auto powered = std::get<rtu::ReadHoldingRegistersResponse>(ask(drive, read_block, at(21.0))).values;
    EXPECT_EQ(powered[0], read_one(drive, 0xFD01, at(21.0)));
    EXPECT_NE(powered[0], 0);  // ready
    // The write block now writes FA01 then FA00.
    EXPECT_EQ(ask(drive, rtu::WriteMultipleRegisters{0x1870, {2000, 0xC400}}, at(21.0)),
              rtu::Response(rtu::WriteMultipleRegistersResponse{0x1870, 2}));
    EXPECT_EQ(read_one(drive, 0xFA01, at(21.0)), 2000);
    EXPECT_EQ(read_one(drive, 0xFA00, at(21.0)), 0xC400);
}

TEST_F(Atv21, ReadIndirectBlockErrors) {
    EXPECT_EQ(exception_of(ask(drive, rtu::ReadHoldingRegisters{0x1876, 2}, at(0))), ExceptionCode::IllegalDataValue);
    EXPECT_EQ(exception_of(ask(drive, rtu::ReadHoldingRegisters{0x1875, 6}, at(0))), ExceptionCode::IllegalDataValue);
    // Unselected slots read as 0.
    const auto reply = ask(drive, rtu::ReadHoldingRegisters{0x1875, 3}, at(0));
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(reply).values, (rtu::RegisterValues{0, 0, 0}));
}

TEST_F(Atv21, WriteSingleRegisterCases) {
    // Guide 7.6: FA01 = 60 Hz is echoed; 0xFFFF is not a register -> exception 2.
    EXPECT_EQ(ask(drive, rtu::WriteSingleRegister{0xFA01, 0x1770}, at(0)),
              rtu::Response(rtu::WriteSingleRegisterResponse{0xFA01, 0x1770}));
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteSingleRegister{0xFFFF, 0}, at(0))), ExceptionCode::IllegalDataAddress);
    // Read-only register -> exception 2 (7.10).
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteSingleRegister{0xFD00, 1}, at(0))), ExceptionCode::IllegalDataAddress);
    // Outside the range -> exception 3: F803 is 0-100 s, FA01 at most FH (80 Hz).
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteSingleRegister{0x0803, 101}, at(0))), ExceptionCode::IllegalDataValue);
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteSingleRegister{0xFA01, 8001}, at(0))), ExceptionCode::IllegalDataValue);
    EXPECT_FALSE(exception_of(ask(drive, rtu::WriteSingleRegister{0xFA01, 8000}, at(0))).has_value());
}

TEST_F(Atv21, WriteOneWordWithFunction16) {
    const auto reply = ask(drive, rtu::WriteMultipleRegisters{0xFA01, {0x1770}}, at(0));
    EXPECT_EQ(reply, rtu::Response(rtu::WriteMultipleRegistersResponse{0xFA01, 1}));
    EXPECT_EQ(read_one(drive, 0xFA01, at(0)), 0x1770);
}

TEST_F(Atv21, WriteIndirectBlock) {
    // Guide 7.8: F870 = FA00, F871 = FA01; 0xC400 and 60 Hz start the motor forward.
    const rtu::WriteMultipleRegisters block{0x1870, {kRunForwardWithPriority, 0x1770}};
    EXPECT_EQ(exception_of(ask(drive, block, at(0))), ExceptionCode::ServerDeviceFailure);  // F870 = 0
    write(0x0870, 1, 0.0);
    write(0x0871, 3, 0.0);
    drive.power_cycle(at(0.0));  // in effect after a reset (section 6)
    write(0x0803, 0, 0.0);
    EXPECT_EQ(ask(drive, block, at(0)), rtu::Response(rtu::WriteMultipleRegistersResponse{0x1870, 2}));
    EXPECT_EQ(read_one(drive, 0xFA00, at(0)), kRunForwardWithPriority);
    EXPECT_EQ(read_one(drive, 0xFA01, at(0)), 0x1770);
    EXPECT_EQ(read_one(drive, 0xFD00, at(30)), 6000);
    // Wrong start, wrong quantity: exception 3.
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteMultipleRegisters{0x1871, {1, 2}}, at(31))),
              ExceptionCode::IllegalDataValue);
    EXPECT_EQ(exception_of(ask(drive, rtu::WriteMultipleRegisters{0x1870, {1, 2, 3}}, at(31))),
              ExceptionCode::IllegalDataValue);
}

TEST_F(Atv21, DeviceIdentification) {
    const auto reply = ask(drive, rtu::ReadDeviceIdentification{rtu::DeviceIdCode::Basic, 0}, at(0));
    const auto& id = std::get<rtu::DeviceIdentificationResponse>(reply);
    ASSERT_EQ(id.objects.size(), 3U);
    EXPECT_EQ(id.objects[0].value, profile->identification->vendor_name);
    EXPECT_EQ(id.objects[1].value, "ATV21H075M3X");
    EXPECT_EQ(id.objects[2].value, "0201");
    EXPECT_EQ(exception_of(ask(drive, rtu::ReadDeviceIdentification{rtu::DeviceIdCode::Specific, 0}, at(0))),
              ExceptionCode::IllegalDataValue);
}

TEST_F(Atv21, RampsToTheReferenceAtTheAccelerationRate) {
    // ACC 10.0 s from 0 to FH 80 Hz: 8 Hz per second.
    write(0xFA01, 6000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(5.0)), 4000);
    const std::uint16_t status = read_one(drive, 0xFD01, at(5.0));
    EXPECT_NE(status & (1U << 10), 0U);  // running
    EXPECT_NE(status & (1U << 14), 0U);  // ready
    EXPECT_EQ(status & (1U << 9), 0U);   // forward
    EXPECT_EQ(read_one(drive, 0xFD00, at(7.5)), 6000);
    EXPECT_EQ(read_one(drive, 0xFD00, at(9.0)), 6000);
    // Stop: decelerates at the same rate.
    write(0xFA00, 0xC000, 9.0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(11.0)), 4400);
    EXPECT_EQ(read_one(drive, 0xFD00, at(20.0)), 0);
    EXPECT_EQ(read_one(drive, 0xFD01, at(20.0)) & (1U << 10), 0U);
}

TEST_F(Atv21, WithoutPriorityBitsTheTerminalsCommand) {
    // CMOD = terminals (factory): run without bit 15 does nothing.
    write(0xFA01, 6000, 0.0);
    write(0xFA00, 0x0400, 0.0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(10.0)), 0);
    ASSERT_TRUE(drive.set_option("cmod", 2));         // serial link commands...
    EXPECT_EQ(read_one(drive, 0xFD00, at(20.0)), 0);  // ...but the reference is still VIA (0 Hz)
    ASSERT_TRUE(drive.set_option("fmod", 4));
    EXPECT_GT(read_one(drive, 0xFD00, at(30.0)), 0);
}

TEST_F(Atv21, ReverseAndFreewheel) {
    write(0xFA01, 3000, 0.0);
    write(0xFA00, kRunReverseWithPriority, 0.0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(10.0)), 3000);
    EXPECT_NE(read_one(drive, 0xFD01, at(10.0)) & (1U << 9), 0U);
    write(0xFA00, kRunReverseWithPriority | (1U << 11), 10.0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(10.0)), 0);  // coasting: output off at once
    EXPECT_NE(read_one(drive, 0xFD01, at(10.0)) & (1U << 11), 0U);
}

TEST_F(Atv21, CurrentFollowsTheLoad) {
    write(0xFA01, 5000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    ASSERT_TRUE(drive.set_option("load", 20));
    const std::uint16_t light = read_one(drive, 0xFE03, at(10.0));
    ASSERT_TRUE(drive.set_option("load", 100));
    const std::uint16_t heavy = read_one(drive, 0xFE03, at(10.5));
    EXPECT_GT(heavy, light);
    EXPECT_GT(read_one(drive, 0xFE05, at(10.5)), 0);  // voltage follows the frequency
    write(0xFA00, 0xC000, 11.0);
    EXPECT_EQ(read_one(drive, 0xFE03, at(30.0)), 0);
}

TEST_F(Atv21, EmergencyStopTripsAndFaultResetClears) {
    write(0xFA01, 3000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    write(0xFA00, kRunForwardWithPriority | (1U << 12), 5.0);
    EXPECT_EQ(read_one(drive, 0xFC90, at(5.0)), Atv21Drive::kFaultEmergencyStop);
    EXPECT_EQ(read_one(drive, 0xFE10, at(5.0)), Atv21Drive::kFaultEmergencyStop);
    const std::uint16_t status = read_one(drive, 0xFD01, at(5.0));
    EXPECT_EQ(status & 0x1003U, 0x1003U);  // FL output, fault, emergency stop
    EXPECT_EQ(read_one(drive, 0xFD00, at(5.0)), 0);
    write(0xFA00, 0xC000 | (1U << 13), 6.0);
    EXPECT_EQ(read_one(drive, 0xFC90, at(6.0)), 0);
    EXPECT_EQ(read_one(drive, 0xFD01, at(6.0)) & 0x3U, 0U);
    EXPECT_EQ(read_one(drive, 0xFE10, at(6.0)), Atv21Drive::kFaultEmergencyStop);  // history stays
}

TEST_F(Atv21, ModbusTimeoutTripsWithErr5) {
    Atv21Drive fresh{1, profile};
    EXPECT_EQ(read_one(fresh, 0x0803, at(0.0)), 3);  // factory setting
    write(0x0803, 3, 0.0);                           // the clock starts at the first request to this address
    write(0xFA01, 3000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    EXPECT_EQ(read_one(drive, 0xFC90, at(2.9)), 0);
    EXPECT_EQ(read_one(drive, 0xFC90, at(5.8)), 0);  // 2.9 s after the last request
    // 3.5 s of silence: tripped 3 s after the last request, seen by the next one.
    EXPECT_EQ(read_one(drive, 0xFC90, at(9.3)), Atv21Drive::kFaultModbusTimeout);
    EXPECT_EQ(read_one(drive, 0xFE10, at(9.3)), Atv21Drive::kFaultModbusTimeout);
    EXPECT_NE(read_one(drive, 0xFD01, at(9.3)) & 0x2U, 0U);
    EXPECT_EQ(read_one(drive, 0xFD00, at(9.3)), 0);  // F603 = 0: freewheel
    EXPECT_TRUE(drive.faulted());
}

TEST_F(Atv21, ModbusTimeoutWithDecelerationStop) {
    write(0x0803, 3, 0.0);
    write(0x0603, 1, 0.0);  // F603: deceleration stop
    write(0xFA01, 8000, 0.0);
    write(0xFA00, kRunForwardWithPriority, 0.0);
    EXPECT_EQ(read_one(drive, 0xFD00, at(2.0)), 1600);
    // Trip at 5.0 s (3 s after the read at 2.0), when the motor is at 40 Hz; it then decelerates.
    EXPECT_EQ(read_one(drive, 0xFD00, at(6.0)), 4000 - 800);
    EXPECT_EQ(read_one(drive, 0xFC90, at(6.0)), Atv21Drive::kFaultModbusTimeout);
}

TEST_F(Atv21, NoTimeoutBeforeCommunicationOrWhenDisabled) {
    Atv21Drive quiet{2, profile};
    EXPECT_EQ(read_one(quiet, 0xFC90, at(100.0)), 0);  // first request ever: the clock starts
    EXPECT_EQ(read_one(quiet, 0xFC90, at(102.0)), 0);
    EXPECT_EQ(read_one(quiet, 0xFC90, at(106.0)), Atv21Drive::kFaultModbusTimeout);
    EXPECT_EQ(read_one(drive, 0xFC90, at(500.0)), 0);  // F803 = 0: disabled
}

TEST_F(Atv21, BroadcastsDoNotFeedTheTimeout) {
    write(0x0803, 3, 0.0);
    write(0xFA01, 1000, 0.0);
    (void)drive.handle(rtu::WriteSingleRegister{0xFA01, 2000}, true, at(2.0));
    EXPECT_EQ(read_one(drive, 0xFC90, at(3.5)), Atv21Drive::kFaultModbusTimeout);
    EXPECT_EQ(read_one(drive, 0xFA01, at(3.5)), 2000);  // the broadcast itself was obeyed
}

}  // namespace
}  // namespace drivebus::sim
