// SPDX-License-Identifier: Apache-2.0
// The direction-control methods, driven as the bus loop drives them, with a fake UART and a
// recording GPIO line: when the driver is enabled and released relative to the write and to
// the transmit tracker.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "fakes.hpp"
#include "serial/direction.hpp"
#include "serial/gpio_line.hpp"
#include "serial/pty.hpp"
#include "serial/tx_tracker.hpp"

namespace drivebus::serial {
namespace {

using namespace std::chrono_literals;
using test::FakeUart;
using test::kT0;
using test::RecordingLine;

const rtu::CharacterTiming k19200 = rtu::character_timing({19200, 8, rtu::Parity::Even, 1}).value();
constexpr int kFd = 5;
// How long write() takes to return in these scenarios.
constexpr rtu::Duration kWriteCost = 40us;

struct Exchange {
    rtu::Instant written;
    rtu::Instant done;
};

// The bus loop's order: before_transmit, write, started; then check at each next_check()
// until done, and transmit_done at that time.
Exchange transmit(Direction& direction, TransmitTracker& tracker, rtu::Instant at, std::size_t bytes) {
    EXPECT_TRUE(direction.before_transmit(at).has_value());
    const rtu::Instant written = at + kWriteCost;
    tracker.started(written, bytes);
    std::optional<rtu::Instant> done;
    for (int i = 0; i < 10'000 && !done; ++i) {
        done = tracker.check(tracker.next_check());
    }
    EXPECT_TRUE(done.has_value());
    EXPECT_TRUE(direction.transmit_done(done.value_or(at)).has_value());
    return {written, done.value_or(at)};
}

class GpioDirectionTest : public ::testing::Test {
protected:
    std::vector<bool> sets;
    bool fail = false;
    std::unique_ptr<Direction> direction = make_gpio_direction(std::make_unique<RecordingLine>(sets, fail));
    FakeUart uart;
    TransmitTracker tracker{k19200, uart, kFd};
};

TEST_F(GpioDirectionTest, IsReleasedByTheLoop) {
    EXPECT_EQ(direction->name(), "gpio");
    EXPECT_TRUE(direction->needs_release());
    EXPECT_TRUE(direction->edges().empty());
    EXPECT_TRUE(sets.empty()) << "the factory over a line must not drive it";
}

TEST_F(GpioDirectionTest, WithoutTemtReleasesAtTheComputedEndNeverBefore) {
    const auto x = transmit(*direction, tracker, kT0, 8);
    ASSERT_EQ(direction->edges().size(), 2U);
    EXPECT_TRUE(direction->edges()[0].enabled);
    EXPECT_EQ(direction->edges()[0].at, kT0);
    EXPECT_LT(direction->edges()[0].at, x.written);
    EXPECT_FALSE(direction->edges()[1].enabled);
    const rtu::Instant wire_end = x.written + 8 * k19200.character;
    EXPECT_EQ(x.done, wire_end);
    EXPECT_EQ(direction->edges()[1].at, wire_end);
    EXPECT_EQ(sets, (std::vector<bool>{true, false}));
}

TEST_F(GpioDirectionTest, TemtEmptyAtTheFirstCheckReleasesThere) {
    uart.script = {true};
    const auto x = transmit(*direction, tracker, kT0, 8);
    EXPECT_EQ(direction->edges().at(1).at, x.written + 8 * k19200.character);
    EXPECT_EQ(uart.lsr_calls, 1);
}

TEST_F(GpioDirectionTest, TemtEmptyLateReleasesAtTheCheckThatSawIt) {
    uart.script = {false, false, false, true};
    const auto x = transmit(*direction, tracker, kT0, 8);
    const rtu::Instant seen = x.written + 8 * k19200.character + 3 * (k19200.character / 4);
    EXPECT_EQ(x.done, seen);
    EXPECT_EQ(direction->edges().at(1).at, seen);
    EXPECT_EQ(uart.lsr_calls, 4);
}

TEST_F(GpioDirectionTest, EdgesOfConsecutiveRequestsAlternate) {
    const auto first = transmit(*direction, tracker, kT0, 8);
    const auto second = transmit(*direction, tracker, first.done + 20ms, 6);
    ASSERT_EQ(direction->edges().size(), 4U);
    for (std::size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(direction->edges()[i].enabled, i % 2 == 0) << i;
    }
    EXPECT_EQ(direction->edges()[2].at, first.done + 20ms);
    EXPECT_EQ(direction->edges()[3].at, second.written + 6 * k19200.character);
    EXPECT_EQ(sets, (std::vector<bool>{true, false, true, false}));
}

TEST_F(GpioDirectionTest, ARequestWrittenInPiecesIsOneEdgePair) {
    ASSERT_TRUE(direction->before_transmit(kT0));
    tracker.started(kT0 + kWriteCost, 4);
    ASSERT_TRUE(direction->before_transmit(kT0 + 100us));
    tracker.started(kT0 + 140us, 4);
    const auto done = tracker.check(tracker.next_check());
    ASSERT_TRUE(done.has_value());
    ASSERT_TRUE(direction->transmit_done(*done));
    EXPECT_EQ(*done, kT0 + kWriteCost + 8 * k19200.character);
    EXPECT_EQ(direction->edges().size(), 2U);
    EXPECT_EQ(sets, (std::vector<bool>{true, false}));
}

TEST_F(GpioDirectionTest, ALineErrorIsReportedAndNoEdgeRecorded) {
    fail = true;
    const auto enabled = direction->before_transmit(kT0);
    ASSERT_FALSE(enabled.has_value());
    EXPECT_EQ(enabled.error().message, "gpio test line 1: setting it failed: Input/output error");
    EXPECT_TRUE(direction->edges().empty());
    // The state is unknown after a failure, so the release is driven, not skipped.
    fail = false;
    ASSERT_TRUE(direction->transmit_done(kT0 + 1ms));
    EXPECT_EQ(sets, (std::vector<bool>{false}));
    ASSERT_EQ(direction->edges().size(), 1U);
    EXPECT_FALSE(direction->edges()[0].enabled);
}

TEST(RtsDirectionTest, ReleasesAtCreationThenAssertsAroundEachRequest) {
    FakeUart uart;
    uart.script = {false, true};
    auto direction = make_rts_direction(kFd, uart);
    EXPECT_EQ(direction->name(), "rts");
    EXPECT_TRUE(direction->needs_release());
    // Opening the tty raised RTS; the method drops it before anything is sent.
    ASSERT_EQ(uart.rts, (std::vector<FakeUart::RtsCall>{{kFd, false}}));
    EXPECT_TRUE(direction->edges().empty());

    TransmitTracker tracker(k19200, uart, kFd);
    const auto x = transmit(*direction, tracker, kT0, 8);
    EXPECT_EQ(uart.rts, (std::vector<FakeUart::RtsCall>{{kFd, false}, {kFd, true}, {kFd, false}}));
    ASSERT_EQ(direction->edges().size(), 2U);
    EXPECT_LT(direction->edges()[0].at, x.written);
    EXPECT_EQ(direction->edges()[1].at, x.written + 8 * k19200.character + k19200.character / 4);
}

TEST(RtsDirectionTest, InvertedRtsDeassertsWhileSending) {
    FakeUart uart;
    auto direction = make_rts_direction(kFd, uart, RtsOptions{.rts_on_send = false});
    TransmitTracker tracker(k19200, uart, kFd);
    const auto x = transmit(*direction, tracker, kT0, 3);
    EXPECT_EQ(uart.rts, (std::vector<FakeUart::RtsCall>{{kFd, true}, {kFd, false}, {kFd, true}}));
    EXPECT_EQ(direction->edges().at(1).at, x.written + 3 * k19200.character);
}

TEST(RtsDirectionTest, AnRtsErrorNamesTheCall) {
    FakeUart uart;
    uart.fail_rts = true;
    auto direction = make_rts_direction(kFd, uart);
    const auto enabled = direction->before_transmit(kT0);
    ASSERT_FALSE(enabled.has_value());
    EXPECT_NE(enabled.error().message.find(": RTS on for the driver enable: TIOCMBIS: Inappropriate ioctl for device"),
              std::string::npos)
        << enabled.error().message;
    EXPECT_TRUE(direction->edges().empty());
}

TEST(NoDirectionTest, RecordsEdgesAndNeedsNoRelease) {
    auto direction = make_no_direction();
    EXPECT_EQ(direction->name(), "none");
    EXPECT_FALSE(direction->needs_release());
    FakeUart uart;
    TransmitTracker tracker(k19200, uart, kFd);
    const auto x = transmit(*direction, tracker, kT0, 8);
    ASSERT_EQ(direction->edges().size(), 2U);
    EXPECT_EQ(direction->edges()[0].at, kT0);
    EXPECT_EQ(direction->edges()[1].at, x.done);
    direction->clear_edges();
    EXPECT_TRUE(direction->edges().empty());
    EXPECT_TRUE(uart.rts.empty());
}

TEST(KernelDirectionTest, APtyHasNoRs485Support) {
    auto pty = open_pty();
    ASSERT_TRUE(pty.has_value()) << pty.error().message();
    const auto direction = make_kernel_direction(pty->slave.get(), KernelRs485Options{});
    ASSERT_FALSE(direction.has_value());
    EXPECT_EQ(direction.error().message, pty->slave_path.string() +
                                             ": the driver has no RS485 support (TIOCGRS485: Inappropriate ioctl "
                                             "for device)");
    EXPECT_TRUE(direction.error().permanent);
    EXPECT_TRUE(direction.error().no_rs485_support);  // the one case a kernel_fallback takes
}

TEST(GpioOptionsTest, AMissingChipIsOneClearLine) {
    if (!gpio_chips().empty()) {
        GTEST_SKIP() << "this machine has GPIO chips";
    }
    const auto direction = make_gpio_direction(GpioOptions{.chip = "gpiochip0", .line = 17, .active_low = false});
    ASSERT_FALSE(direction.has_value());
    EXPECT_EQ(direction.error().message,
              "gpio gpiochip0 line 17: no such GPIO chip (no /dev/gpiochip* on this machine)");
}

TEST(GpioOptionsTest, AnUnknownChipNameIsRefused) {
    const auto direction = make_gpio_direction(GpioOptions{.chip = "drivebus-no-such-chip", .line = 3});
    ASSERT_FALSE(direction.has_value());
    EXPECT_TRUE(direction.error().message.starts_with("gpio drivebus-no-such-chip line 3: no such GPIO chip ("))
        << direction.error().message;
}

TEST(GpioOptionsTest, ChipsAreListedFromTheDeviceDirectory) {
    const auto dir = std::filesystem::temp_directory_path() / ("drivebus-gpio-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    for (const char* name : {"gpiochip1", "ttyS0", "gpiochip0"}) {
        std::ofstream(dir / name).put('x');
    }
    EXPECT_EQ(gpio_chips(dir), (std::vector<std::string>{"gpiochip0", "gpiochip1"}));
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace drivebus::serial
