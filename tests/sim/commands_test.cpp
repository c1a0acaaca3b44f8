// SPDX-License-Identifier: Apache-2.0
// Control socket commands and the --fault / --option arguments.
#include "commands.hpp"

#include <gtest/gtest.h>

#include "sim_fixture.hpp"

namespace drivebus::sim {
namespace {

using namespace std::chrono_literals;

class Commands : public ::testing::Test {
protected:
    Bus bus{{rtu::character_timing({19200, 8, rtu::Parity::None, 1}).value(), 1ms, true, 1}};
    void SetUp() override {
        bus.add(make_drive(1, test::profile("atv21")));
        bus.add(make_drive(2, test::profile("atv58")));
    }
    std::string run(std::string_view line) { return run_command(bus, line, test::at(0)); }
};

TEST_F(Commands, ListsDrivesAndStats) {
    EXPECT_EQ(run("drives"), "ok 1:atv21 2:atv58");
    EXPECT_EQ(run("stats").rfind("ok requests=0 ", 0), 0U);
    EXPECT_EQ(run("help").rfind("ok commands:", 0), 0U);
}

TEST_F(Commands, FaultsChangeAndClear) {
    EXPECT_EQ(run("fault 1 crc=0.5 late=2ms").rfind("ok ", 0), 0U);
    EXPECT_EQ(bus.faults().for_drive(1).crc, 0.5);
    EXPECT_EQ(bus.faults().for_drive(1).late, 2ms);
    EXPECT_EQ(run("fault * echo=1").rfind("ok echo=1", 0), 0U);
    EXPECT_TRUE(bus.faults().echo());
    EXPECT_EQ(run("clear 1").rfind("ok ", 0), 0U);
    EXPECT_EQ(bus.faults().for_drive(1).crc, 0.0);
    EXPECT_TRUE(bus.faults().echo());
    EXPECT_EQ(run("clear").rfind("ok echo=0", 0), 0U);
}

TEST_F(Commands, BadFaultCommandsChangeNothing) {
    EXPECT_EQ(run("fault 1 crc=0.25").rfind("ok", 0), 0U);
    EXPECT_EQ(run("fault 1 drop=1 crc=7"), "error: crc: share must be between 0 and 1, got 7");
    EXPECT_EQ(bus.faults().for_drive(1).drop, 0.0);  // the valid half was not applied either
    EXPECT_EQ(bus.faults().for_drive(1).crc, 0.25);
    EXPECT_EQ(run("fault 9 crc=1"), "error: no simulated drive at address 9");
    EXPECT_EQ(run("fault x crc=1"), "error: 'x' is not a slave address (1-247) or *");
    EXPECT_EQ(run("frobnicate").rfind("error: cannot parse", 0), 0U);
}

TEST_F(Commands, GetAndSetRegisters) {
    EXPECT_EQ(run("get 1 FA01"), "ok 0");
    EXPECT_EQ(run("set 1 fa01 0x1770"), "ok");
    EXPECT_EQ(run("get 1 FA01"), "ok 6000");
    EXPECT_EQ(run("set 2 W453 77"), "ok");
    EXPECT_EQ(run("get 2 W453"), "ok 77");
    EXPECT_EQ(run("get 2 FA01"), "error: no register FA01 in profile atv58");
    EXPECT_EQ(run("set 1 FA01 70000").rfind("error: '70000' is not a 16-bit value", 0), 0U);
}

// power: the drive is switched off and on; the Altivar 21 forgets its RAM parameters and
// applies the block selectors it stores; another drive keeps its registers.
TEST_F(Commands, PowerCycleADrive) {
    EXPECT_EQ(run("set 1 FA01 3000"), "ok");
    EXPECT_EQ(run("set 1 F875 2"), "ok");
    EXPECT_EQ(run("set 2 W453 77"), "ok");
    EXPECT_EQ(run("power 1"), "ok");
    EXPECT_EQ(run("power 2"), "ok");
    EXPECT_EQ(run("get 1 FA01"), "ok 0");
    EXPECT_EQ(run("get 1 F875"), "ok 2");
    EXPECT_EQ(run("get 2 W453"), "ok 77");
    EXPECT_EQ(run("power 9"), "error: no simulated drive at address 9");
    EXPECT_EQ(run("power *"), "error: '*' is not a slave address (1-247)");
    EXPECT_EQ(run("power").rfind("error: cannot parse", 0), 0U);
}

TEST_F(Commands, DriveOptions) {
    EXPECT_EQ(run("option 1 load=80"), "ok");
    EXPECT_EQ(run("option 2 load=80"), "error: drive 2 (atv58) has no option 'load'");
    EXPECT_EQ(run("option 1 load=lots"), "error: option load: 'lots' is not a number");
}

TEST_F(Commands, CommandLineArguments) {
    EXPECT_TRUE(apply_fault_argument(bus, "drop=0.1").has_value());
    EXPECT_EQ(bus.faults().for_drive(2).drop, 0.1);  // line-wide default
    EXPECT_TRUE(apply_fault_argument(bus, "1:gap=3:2").has_value());
    EXPECT_EQ(bus.faults().for_drive(1).gap_at, 3U);
    EXPECT_EQ(apply_fault_argument(bus, "7:crc=1").error(), "--fault 7:crc=1: no simulated drive at address 7");
    EXPECT_TRUE(apply_option_argument(bus, "1:fh=60").has_value());
    EXPECT_FALSE(apply_option_argument(bus, "load=5").has_value());
}

// --set: the Altivar 21's Modbus time-out (F803, factory 3 s) and its fault behaviour (F603)
// from the start, as a pump whose time-out is off.
TEST_F(Commands, SetArgumentsGiveRegistersTheirStartingValues) {
    EXPECT_EQ(bus.drive(1)->peek("F803").value(), 3);  // the factory setting
    EXPECT_EQ(bus.drive(1)->peek("F603").value(), 0);
    EXPECT_TRUE(apply_set_argument(bus, "1:F803=0").has_value());
    EXPECT_TRUE(apply_set_argument(bus, "1:f603=0x0001").has_value());
    EXPECT_EQ(bus.drive(1)->peek("F803").value(), 0);
    EXPECT_EQ(bus.drive(1)->peek("F603").value(), 1);
    EXPECT_EQ(apply_set_argument(bus, "1:F803").error(), "'1:F803' is not ADDR:REG=VALUE");
    EXPECT_EQ(apply_set_argument(bus, "1:F803=70000").error(),
              "'70000' is not a 16-bit value (0-65535 or 0x0000-0xFFFF)");
    EXPECT_EQ(apply_set_argument(bus, "7:F803=0").error(), "no simulated drive at address 7");
    EXPECT_FALSE(apply_set_argument(bus, "1:XX99=0").has_value());
    // And over Modbus, within the guide's range.
    EXPECT_EQ(test::read_one(*bus.drive(1), 0x0803, test::at(0)), 0);
    const auto written = test::ask(*bus.drive(1), rtu::WriteSingleRegister{0x0803, 5}, test::at(0));
    EXPECT_TRUE(std::holds_alternative<rtu::WriteSingleRegisterResponse>(written));
    EXPECT_EQ(bus.drive(1)->peek("F803").value(), 5);
    const auto refused = test::ask(*bus.drive(1), rtu::WriteSingleRegister{0x0803, 101}, test::at(0));
    EXPECT_TRUE(std::holds_alternative<rtu::ExceptionResponse>(refused));
}

}  // namespace
}  // namespace drivebus::sim
