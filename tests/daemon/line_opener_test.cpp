// SPDX-License-Identifier: Apache-2.0
// The bus's direction control as drivebusd makes it, on a pty (a driver without RS485
// support): kernel_fallback is taken for that and only that, and check_line() says what to
// do. A driver that changes the RS485 settings asked is checked on the PL011 in the board
// stage (tests/board/guest_test.cpp, Packaged.DrivebusdRefusesWhatTheDriverChanges).
#include <gtest/gtest.h>

#include "bus/line_opener.hpp"
#include "fakes.hpp"
#include "serial/pty.hpp"

namespace drivebus::bus {
namespace {

config::BusConfig kernel_bus(const std::filesystem::path& device, std::optional<config::DirectionMode> fallback) {
    config::BusConfig bus;
    bus.name = "line";
    bus.device = device;
    bus.direction = config::DirectionMode::Kernel;
    bus.kernel_fallback = fallback;
    return bus;
}

TEST(MakeDirection, ADriverWithoutRs485SupportTakesTheFallbackAsked) {
    auto pty = serial::open_pty();
    ASSERT_TRUE(pty.has_value()) << pty.error().message();
    serial::test::FakeUart uart;
    const int fd = pty->slave.get();

    auto rts = make_direction(kernel_bus(pty->slave_path, config::DirectionMode::Rts), fd, uart);
    ASSERT_TRUE(rts.has_value()) << rts.error().message;
    EXPECT_EQ((*rts)->name(), "rts");
    ASSERT_FALSE(uart.rts.empty()) << "the rts fallback did not set RTS to its release level";
    EXPECT_EQ(uart.rts.back(), (serial::test::FakeUart::RtsCall{fd, false}));

    auto none = make_direction(kernel_bus(pty->slave_path, config::DirectionMode::None), fd, uart);
    ASSERT_TRUE(none.has_value()) << none.error().message;
    EXPECT_EQ((*none)->name(), "none");

    auto refused = make_direction(kernel_bus(pty->slave_path, std::nullopt), fd, uart);
    ASSERT_FALSE(refused.has_value());
    EXPECT_TRUE(refused.error().permanent);
    EXPECT_TRUE(refused.error().no_rs485_support);
    EXPECT_NE(refused.error().message.find("the driver has no RS485 support"), std::string::npos)
        << refused.error().message;
}

TEST(CheckLine, ADriverWithoutRs485SupportIsAnErrorOnlyWithoutAFallback) {
    auto pty = serial::open_pty();
    ASSERT_TRUE(pty.has_value()) << pty.error().message();
    for (const auto fallback : {config::DirectionMode::Rts, config::DirectionMode::None}) {
        const auto checked = check_line(kernel_bus(pty->slave_path, fallback));
        EXPECT_TRUE(checked.has_value()) << checked.error();
    }
    const auto refused = check_line(kernel_bus(pty->slave_path, std::nullopt));
    ASSERT_FALSE(refused.has_value());
    EXPECT_EQ(refused.error(), "bus line: " + pty->slave_path.string() +
                                   ": the driver has no RS485 support (TIOCGRS485: Inappropriate ioctl for device); "
                                   "set kernel_fallback = \"rts\" or \"none\", or another direction");
}

TEST(CheckLine, ADeviceNotThereYetIsLeftToTheBusThread) {
    const auto checked = check_line(kernel_bus("/dev/drivebus-no-such-adapter", std::nullopt));
    EXPECT_TRUE(checked.has_value()) << checked.error();
}

}  // namespace
}  // namespace drivebus::bus
