// SPDX-License-Identifier: Apache-2.0
// The transmit tracker: computed wire times, TIOCSERGETLSR polling and the cap.
#include <gtest/gtest.h>

#include "fakes.hpp"
#include "serial/tx_tracker.hpp"

namespace drivebus::serial {
namespace {

using namespace std::chrono_literals;
using test::FakeUart;
using test::kT0;

// 9600 8N1: 10 bits, 1041666.7 ns rounded; 19200 8E1: 11 bits, 572916.7 ns rounded.
const rtu::CharacterTiming k9600 = rtu::character_timing({9600, 8, rtu::Parity::None, 1}).value();
const rtu::CharacterTiming k19200 = rtu::character_timing({19200, 8, rtu::Parity::Even, 1}).value();
constexpr int kFd = 7;

TEST(TransmitTrackerTest, CharacterTimesAreTheOnesTheTestsAssume) {
    EXPECT_EQ(k9600.character, 1'041'667ns);
    EXPECT_EQ(k19200.character, 572'917ns);
}

TEST(TransmitTrackerTest, ComputedEndAt9600WhenTheDriverCannotTell) {
    FakeUart uart;  // TIOCSERGETLSR unsupported
    TransmitTracker tracker(k9600, uart, kFd);
    EXPECT_FALSE(tracker.busy());
    tracker.started(kT0, 8);
    EXPECT_TRUE(tracker.busy());
    const rtu::Instant end = kT0 + 8'333'336ns;  // 8 x 1041667 ns
    EXPECT_EQ(tracker.next_check(), end);
    EXPECT_EQ(tracker.check(end - 1ns), std::nullopt);
    EXPECT_EQ(uart.lsr_calls, 0) << "asked the UART before the computed end";
    EXPECT_EQ(tracker.check(end), end);
    EXPECT_FALSE(tracker.busy());
    EXPECT_FALSE(tracker.lsr_supported());
    EXPECT_EQ(uart.lsr_calls, 1);

    // A late loop still gets the computed time, and the driver is not asked again.
    tracker.started(kT0 + 100ms, 2);
    const rtu::Instant second = kT0 + 100ms + 2'083'334ns;
    EXPECT_EQ(tracker.check(second + 3ms), second);
    EXPECT_EQ(uart.lsr_calls, 1);
}

TEST(TransmitTrackerTest, BackToBackWritesAt19200QueueBehindEachOther) {
    FakeUart uart;
    TransmitTracker tracker(k19200, uart, kFd);
    tracker.started(kT0, 8);  // on the wire until kT0 + 8c = 4583336 ns
    EXPECT_EQ(tracker.next_check(), kT0 + 4'583'336ns);
    // Queued: starts when the first ends.
    tracker.started(kT0 + 1ms, 5);
    EXPECT_EQ(tracker.next_check(), kT0 + 7'447'921ns);  // 13c
    EXPECT_EQ(tracker.computed_end(), kT0 + 7'447'921ns);
    // Written after the line went quiet: counts from its own write.
    tracker.started(kT0 + 10ms, 1);
    EXPECT_EQ(tracker.next_check(), kT0 + 10ms + 572'917ns);
    EXPECT_EQ(tracker.check(tracker.next_check()), kT0 + 10ms + 572'917ns);
}

TEST(TransmitTrackerTest, BackToBackWritesAt9600) {
    FakeUart uart;
    TransmitTracker tracker(k9600, uart, kFd);
    tracker.started(kT0, 8);
    tracker.started(kT0 + 20us, 8);
    EXPECT_EQ(tracker.next_check(), kT0 + 16'666'672ns);
    // The cap counts from the last write over everything still queued.
    EXPECT_EQ(tracker.cap(), kT0 + 20us + 2 * (16'666'672ns - 20us) + 20ms);
}

TEST(TransmitTrackerTest, EmptyAtTheFirstCheckEndsThere) {
    FakeUart uart;
    uart.script = {true};
    TransmitTracker tracker(k19200, uart, kFd);
    tracker.started(kT0, 8);
    const auto first = tracker.next_check();
    EXPECT_EQ(tracker.check(first), first);
    EXPECT_EQ(uart.lsr_calls, 1);
    EXPECT_TRUE(tracker.lsr_supported());
}

TEST(TransmitTrackerTest, NotYetEmptyIsPolledEveryQuarterCharacter) {
    FakeUart uart;
    uart.script = {false, false, true};
    TransmitTracker tracker(k19200, uart, kFd);
    tracker.started(kT0, 8);
    const auto end = tracker.next_check();
    EXPECT_EQ(tracker.check(end), std::nullopt);
    EXPECT_TRUE(tracker.busy());
    EXPECT_EQ(tracker.next_check(), end + k19200.character / 4);
    // Called early (another event woke the loop): nothing asked, nothing moved.
    EXPECT_EQ(tracker.check(end + 1us), std::nullopt);
    EXPECT_EQ(uart.lsr_calls, 1);
    EXPECT_EQ(tracker.check(tracker.next_check()), std::nullopt);
    EXPECT_EQ(tracker.next_check(), end + 2 * (k19200.character / 4));
    const auto found = tracker.next_check();
    EXPECT_EQ(tracker.check(found), found);
    EXPECT_EQ(uart.lsr_calls, 3);
    EXPECT_EQ(tracker.gave_up(), 0U);
}

TEST(TransmitTrackerTest, TheQuarterCharacterStepCountsFromALateCheck) {
    FakeUart uart;
    uart.script = {false};
    TransmitTracker tracker(k9600, uart, kFd);
    tracker.started(kT0, 4);
    const auto late = tracker.next_check() + 3ms;
    EXPECT_EQ(tracker.check(late), std::nullopt);
    EXPECT_EQ(tracker.next_check(), late + k9600.character / 4);
}

TEST(TransmitTrackerTest, AStuckTransmitterIsGivenUpAtTheCap) {
    FakeUart uart;
    uart.otherwise = false;  // never empty
    TransmitTracker tracker(k9600, uart, kFd);
    tracker.started(kT0, 8);
    const rtu::Instant cap = kT0 + 2 * 8'333'336ns + 20ms;
    EXPECT_EQ(tracker.cap(), cap);
    std::optional<rtu::Instant> done;
    int checks = 0;
    while (!done && checks < 1000) {
        const auto at = tracker.next_check();
        ASSERT_LE(at, cap);
        done = tracker.check(at);
        ++checks;
    }
    ASSERT_TRUE(done.has_value());
    EXPECT_EQ(*done, cap);
    EXPECT_EQ(tracker.gave_up(), 1U);
    EXPECT_FALSE(tracker.busy());
    // (2 x 8.33 ms + 20 ms - 8.33 ms) / (c / 4) quarter characters, and the last at the cap.
    EXPECT_EQ(checks, 1 + 109);
}

TEST(TransmitTrackerTest, DriverThatStopsAnsweringEndsAtTheCheck) {
    FakeUart uart;
    uart.script = {false, std::nullopt};
    TransmitTracker tracker(k9600, uart, kFd);
    tracker.started(kT0, 8);
    const auto end = tracker.next_check();
    EXPECT_EQ(tracker.check(end), std::nullopt);
    const auto second = tracker.next_check();
    // It said "not empty" at the computed end, so the computed end is no answer any more.
    EXPECT_EQ(tracker.check(second), second);
    EXPECT_FALSE(tracker.lsr_supported());
}

TEST(TransmitTrackerTest, IdleCheckRepeatsTheLastResult) {
    FakeUart uart;
    uart.script = {true};
    TransmitTracker tracker(k9600, uart, kFd);
    tracker.started(kT0, 1);
    const auto done = tracker.check(tracker.next_check());
    ASSERT_TRUE(done.has_value());
    EXPECT_EQ(tracker.check(*done + 1s), done);
    EXPECT_EQ(uart.lsr_calls, 1);
}

}  // namespace
}  // namespace drivebus::serial
