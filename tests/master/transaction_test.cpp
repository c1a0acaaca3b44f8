// SPDX-License-Identifier: Apache-2.0
// The transaction state machine on a fake clock.
#include "master/transaction.hpp"

#include <gtest/gtest.h>

#include "rtu/codec.hpp"

namespace drivebus::master {
namespace {

using namespace std::chrono_literals;

const rtu::Instant t0{std::chrono::seconds(10)};
const rtu::RequestAdu kRead{1, rtu::ReadHoldingRegisters{0xFD00, 1}};

Transaction make(unsigned retries = 2, rtu::RequestAdu request = kRead) {
    const auto adu = rtu::encode_request(request).value();
    return Transaction({50ms, retries, 10ms}, request, adu);
}

rtu::Frame frame_of(const rtu::ResponseAdu& reply, rtu::Instant last) {
    rtu::Frame f;
    f.adu = rtu::encode_response(reply).value();
    f.first = last;
    f.last = last;
    return f;
}

TEST(Transaction, ReplyCompletesIt) {
    auto t = make();
    EXPECT_EQ(t.state(), Transaction::State::ReadyToSend);
    t.written(t0);
    EXPECT_EQ(t.state(), Transaction::State::Sending);
    EXPECT_FALSE(t.deadline().has_value());  // the timeout starts when the request is off the wire
    t.sent(t0 + 4ms);
    EXPECT_EQ(t.deadline(), t0 + 54ms);
    const auto verdict = t.on_frame(frame_of({1, rtu::ReadHoldingRegistersResponse{{6000}}}, t0 + 10ms));
    EXPECT_EQ(verdict, Transaction::Verdict::Reply);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Ok);
    EXPECT_EQ(t.result()->latency, 6ms);
    EXPECT_EQ(t.result()->attempts, 1U);
}

TEST(Transaction, ReplyBeforeTheComputedEndOfTransmissionCounts) {
    // Nothing paces a pty pair: the reply can arrive before the request's computed wire time.
    auto t = make();
    t.written(t0);
    EXPECT_EQ(t.on_frame(frame_of({1, rtu::ReadHoldingRegistersResponse{{1}}}, t0 + 1ms)), Transaction::Verdict::Reply);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->latency, 1ms);
    t.sent(t0 + 4ms);  // the transmitter report that follows changes nothing
    EXPECT_EQ(t.state(), Transaction::State::Done);
}

TEST(Transaction, TimeoutsRetryThenGiveUp) {
    auto t = make(2);
    for (int attempt = 1; attempt <= 3; ++attempt) {
        ASSERT_EQ(t.state(), Transaction::State::ReadyToSend) << attempt;
        const rtu::Instant start = t0 + std::chrono::milliseconds(100 * attempt);
        t.written(start);
        t.sent(start + 4ms);
        t.on_time(start + 53ms);
        EXPECT_NE(t.state(), Transaction::State::ReadyToSend);  // not yet
        t.on_time(start + 54ms);
    }
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Timeout);
    EXPECT_EQ(t.result()->attempts, 3U);
}

// A malformed frame from the slave (here two words for a one-word read: perhaps a stale reply
// to another request) spoils the attempt, which still waits out its time-out for the reply.
TEST(Transaction, ForeignFramesAreIgnoredMalformedOnesSpoilTheAttempt) {
    auto t = make(0);
    t.written(t0);
    t.sent(t0 + 4ms);
    EXPECT_EQ(t.on_frame(frame_of({2, rtu::ReadHoldingRegistersResponse{{1}}}, t0 + 8ms)),
              Transaction::Verdict::Foreign);
    EXPECT_EQ(t.state(), Transaction::State::AwaitingReply);
    EXPECT_EQ(t.on_frame(frame_of({1, rtu::ReadHoldingRegistersResponse{{1, 2}}}, t0 + 9ms)),
              Transaction::Verdict::Malformed);
    EXPECT_EQ(t.state(), Transaction::State::AwaitingReply);
    t.on_time(t0 + 54ms);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::BadFrame);
}

TEST(Transaction, ExceptionIsAnAnswer) {
    auto t = make();
    t.written(t0);
    t.sent(t0 + 4ms);
    t.on_frame(frame_of({1, rtu::ExceptionResponse{3, rtu::ExceptionCode::IllegalDataValue}}, t0 + 9ms));
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Exception);
    EXPECT_EQ(t.result()->exception(), rtu::ExceptionCode::IllegalDataValue);
}

// An echo mismatch (the request itself was garbled on the wire: no slave answers it) retries
// at once; a spoiled frame waits out the response time-out and the late-reply guard first.
TEST(Transaction, BadFramesAndEchoMismatchesRetry) {
    const auto adu = rtu::encode_request(kRead).value();
    Transaction t({50ms, 1, 10ms, 30ms}, kRead, adu);
    t.written(t0);
    t.on_echo_mismatch(t0 + 1ms);
    EXPECT_EQ(t.state(), Transaction::State::ReadyToSend);
    t.written(t0 + 10ms);
    t.sent(t0 + 14ms);
    t.on_bad_frame(t0 + 20ms, t0 + 18ms);
    EXPECT_EQ(t.state(), Transaction::State::AwaitingReply);
    t.on_time(t0 + 63ms);
    EXPECT_EQ(t.state(), Transaction::State::AwaitingReply) << "not before the time-out";
    t.on_time(t0 + 64ms);
    EXPECT_EQ(t.state(), Transaction::State::Guard);
    t.on_time(t0 + 94ms);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::BadFrame);
    EXPECT_EQ(t.result()->attempts, 2U);
}

// Noise of a reply's size before the reply: the attempt is spoiled, but the reply that follows
// within the time-out is this attempt's, and taken. Retried at once instead, the retry would
// take this reply and leave its own for the next request.
TEST(Transaction, AReplyAfterASpoiledFrameIsStillTheAttemptsReply) {
    auto t = make(2);
    t.written(t0);
    t.sent(t0 + 4ms);
    t.on_bad_frame(t0 + 10ms, t0 + 8ms);
    EXPECT_EQ(t.state(), Transaction::State::AwaitingReply);
    EXPECT_EQ(t.on_frame(frame_of({1, rtu::ReadHoldingRegistersResponse{{6000}}}, t0 + 20ms)),
              Transaction::Verdict::Reply);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Ok);
    EXPECT_EQ(t.result()->attempts, 1U);
}

TEST(Transaction, ASpoiledFrameThatBeganBeforeTheSlaveCouldAnswerIsNotTheReply) {
    const auto adu = rtu::encode_request(kRead).value();
    Transaction t({50ms, 0, 10ms, {}, 2ms}, kRead, adu);
    t.written(t0);
    t.sent(t0 + 4ms);
    // Began 1 ms after the write: a compliant slave keeps t3.5 (here 2 ms) before it answers.
    t.on_bad_frame(t0 + 6ms, t0 + 1ms);
    EXPECT_EQ(t.state(), Transaction::State::AwaitingReply);
    // A good reply counts whenever it comes (some slaves answer sooner than t3.5).
    auto early = frame_of({1, rtu::ReadHoldingRegistersResponse{{7}}}, t0 + 5ms);
    early.first = t0 + 1ms;
    EXPECT_EQ(t.on_frame(early), Transaction::Verdict::Reply);
}

// After a time-out the transaction waits a guard before it is sent again: a reply in it is
// late, discarded, and reported; a reply to any of its attempts after that is its answer.
TEST(Transaction, ALateReplyIsDiscardedInTheGuardAndReported) {
    const auto adu = rtu::encode_request(kRead).value();
    Transaction t({50ms, 1, 10ms, 50ms, {}}, kRead, adu);
    t.written(t0);
    t.sent(t0 + 4ms);
    t.on_time(t0 + 54ms);
    ASSERT_EQ(t.state(), Transaction::State::Guard);
    t.written(t0 + 60ms);
    EXPECT_EQ(t.state(), Transaction::State::Guard) << "nothing is sent in the guard";
    const auto reply = frame_of({1, rtu::ReadHoldingRegistersResponse{{5}}}, t0 + 75ms);
    EXPECT_EQ(t.on_frame(reply), Transaction::Verdict::Late);
    EXPECT_EQ(t.on_frame(frame_of({2, rtu::ReadHoldingRegistersResponse{{5}}}, t0 + 80ms)),
              Transaction::Verdict::Foreign);
    t.on_time(t0 + 103ms);
    EXPECT_EQ(t.state(), Transaction::State::Guard);
    t.on_time(t0 + 104ms);
    ASSERT_EQ(t.state(), Transaction::State::ReadyToSend);
    t.written(t0 + 110ms);
    t.sent(t0 + 114ms);
    t.on_time(t0 + 164ms);
    EXPECT_EQ(t.on_frame(frame_of({1, rtu::ReadHoldingRegistersResponse{{5}}}, t0 + 185ms)),
              Transaction::Verdict::Late);
    t.on_time(t0 + 214ms);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Late);
    EXPECT_EQ(t.result()->late_replies, 2U);
    EXPECT_EQ(t.result()->late_latency, 71ms);  // 185 ms, less the second attempt's 114 ms
    EXPECT_FALSE(t.result()->response.has_value());
}

TEST(Transaction, AReplyOnARetryIsTheAnswerAndSaysSo) {
    const auto adu = rtu::encode_request(kRead).value();
    Transaction t({50ms, 1, 10ms, 50ms, {}}, kRead, adu);
    t.written(t0);
    t.sent(t0 + 4ms);
    t.on_time(t0 + 54ms);
    t.on_time(t0 + 104ms);
    t.written(t0 + 110ms);
    t.sent(t0 + 114ms);
    EXPECT_EQ(t.on_frame(frame_of({1, rtu::ReadHoldingRegistersResponse{{5}}}, t0 + 130ms)),
              Transaction::Verdict::Reply);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Ok);
    EXPECT_TRUE(t.result()->after_timeout);
}

TEST(Transaction, SilenceEverywhereIsATimeoutNotLate) {
    const auto adu = rtu::encode_request(kRead).value();
    Transaction t({50ms, 0, 10ms, 50ms, {}}, kRead, adu);
    t.written(t0);
    t.sent(t0 + 4ms);
    t.on_time(t0 + 54ms);
    t.on_time(t0 + 104ms);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Timeout);
    EXPECT_EQ(t.result()->late_replies, 0U);
}

TEST(Transaction, BroadcastWaitsTheTurnaroundOnly) {
    auto t = make(2, {0, rtu::WriteSingleRegister{0xFA01, 1}});
    t.written(t0);
    t.sent(t0 + 4ms);
    EXPECT_EQ(t.state(), Transaction::State::BroadcastWait);
    t.on_time(t0 + 13ms);
    EXPECT_EQ(t.state(), Transaction::State::BroadcastWait);
    t.on_time(t0 + 14ms);
    ASSERT_EQ(t.state(), Transaction::State::Done);
    EXPECT_EQ(t.result()->outcome, Outcome::Ok);
    EXPECT_FALSE(t.result()->response.has_value());
}

TEST(Transaction, AbortReportsBusDown) {
    auto t = make();
    t.written(t0);
    t.abort(t0 + 1ms);
    EXPECT_EQ(t.result()->outcome, Outcome::BusDown);
}

}  // namespace
}  // namespace drivebus::master
