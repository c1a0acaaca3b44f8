// SPDX-License-Identifier: Apache-2.0
// Units you can trust, against the running stack: a frequency in Hz reaches the ATV21 in its
// profile's 0.01 Hz, and is refused for the Altivar 58, whose profile gives its reference (W401)
// no unit or scale, without anything reaching that drive; a raw write there says it is raw.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

std::pair<int, std::string> client(const Stack& stack, std::vector<std::string> args) {
    args.insert(args.begin(), {TEST_CLIENT_PATH, stack.bus()});
    return run_program(args);
}

TEST(Units, SetFrequencyWritesTheAtv21InHundredthsOfAHertz) {
    Stack stack;
    const auto [status, out] = client(stack, {"frequency", "pump", "42.5"});
    ASSERT_EQ(status, 0) << out << stack.daemon_output();
    EXPECT_EQ(stack.sim_register(1, "FA01"), 4250);
}

TEST(Units, SetFrequencyOnAReferenceWithoutAUnitIsRefusedAndNothingIsSent) {
    Stack stack;
    const auto before = stack.sim_register(2, "W401");
    const auto [status, out] = client(stack, {"frequency", "fan", "50"});
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("unsupported"), std::string::npos) << out;
    EXPECT_NE(out.find("the atv58 profile gives its frequency reference W401 no unit and scale"), std::string::npos)
        << out;
    EXPECT_EQ(stack.sim_register(2, "W401"), before);
    EXPECT_EQ(stack.sim().command("writes 2").find("0x0191="), std::string::npos) << stack.sim().command("writes 2");
}

TEST(Units, ARawWriteWhereNoUnitExistsSaysItIsRaw) {
    Stack stack;
    const auto [status, out] = run_program({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "write", "fan", "W401", "50"});
    ASSERT_EQ(status, 0) << out;
    EXPECT_NE(out.find("raw word written as given: W401 has no unit in the atv58 profile"), std::string::npos) << out;
    EXPECT_EQ(stack.sim_register(2, "W401"), 50);
    // With a unit, the value is refused rather than guessed.
    const auto [hz_status, hz_out] =
        run_program({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "write", "fan", "W401", "50", "Hz"});
    EXPECT_NE(hz_status, 0) << hz_out;
    EXPECT_NE(hz_out.find("W401 has no unit"), std::string::npos) << hz_out;
    // A register with a unit says nothing of the kind.
    const auto [pump_status, pump_out] =
        run_program({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "write", "pump", "FA01", "30", "Hz"});
    ASSERT_EQ(pump_status, 0) << pump_out;
    EXPECT_EQ(pump_out.find("raw word"), std::string::npos) << pump_out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000);
}

}  // namespace
}  // namespace drivebus::test
