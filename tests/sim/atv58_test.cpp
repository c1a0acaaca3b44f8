// SPDX-License-Identifier: Apache-2.0
// The Altivar 58 model: its manual's function limits and words.
#include <gtest/gtest.h>

#include "sim_fixture.hpp"

namespace drivebus::sim {
namespace {

using rtu::ExceptionCode;
using test::ask;
using test::at;
using test::exception_of;

class Atv58 : public ::testing::Test {
protected:
    std::unique_ptr<ProfileDrive> drive = make_drive(2, test::profile("atv58"));
};

TEST_F(Atv58, ReadsTheSupervisionWords) {
    ASSERT_TRUE(drive->poke("W453", 1234).has_value());
    const auto reply = ask(*drive, rtu::ReadHoldingRegisters{450, 10}, at(0));
    const auto& words = std::get<rtu::ReadHoldingRegistersResponse>(reply);
    ASSERT_EQ(words.values.size(), 10U);
    EXPECT_EQ(words.values[3], 1234);
}

TEST_F(Atv58, QuantityLimits) {
    EXPECT_EQ(exception_of(ask(*drive, rtu::ReadHoldingRegisters{450, 33}, at(0))), ExceptionCode::IllegalDataValue);
    rtu::RegisterValues many;
    for (int i = 0; i < 31; ++i) {
        many.push_back(0);
    }
    EXPECT_EQ(exception_of(ask(*drive, rtu::WriteMultipleRegisters{400, many}, at(0))),
              ExceptionCode::IllegalDataValue);
}

TEST_F(Atv58, CommandAndSetpoint) {
    // The manual's example: 15 to W400 and 400 to W401.
    EXPECT_EQ(ask(*drive, rtu::WriteMultipleRegisters{400, {15, 400}}, at(0)),
              rtu::Response(rtu::WriteMultipleRegistersResponse{400, 2}));
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(ask(*drive, rtu::ReadHoldingRegisters{400, 2}, at(0))).values,
              (rtu::RegisterValues{15, 400}));
}

TEST_F(Atv58, UnknownAndReadOnlyWords) {
    EXPECT_EQ(exception_of(ask(*drive, rtu::ReadHoldingRegisters{402, 1}, at(0))), ExceptionCode::IllegalDataAddress);
    EXPECT_EQ(exception_of(ask(*drive, rtu::ReadHoldingRegisters{449, 2}, at(0))), ExceptionCode::IllegalDataAddress);
    EXPECT_EQ(exception_of(ask(*drive, rtu::WriteSingleRegister{450, 1}, at(0))), ExceptionCode::IllegalDataAddress);
}

TEST_F(Atv58, NoDeviceIdentification) {
    EXPECT_EQ(exception_of(ask(*drive, rtu::ReadDeviceIdentification{}, at(0))), ExceptionCode::IllegalFunction);
}

}  // namespace
}  // namespace drivebus::sim
