// SPDX-License-Identifier: Apache-2.0
// The scheduler on a fake clock: read planning within drive limits, priorities, fairness,
// absent drives and their back-off.
#include "master/scheduler.hpp"

#include <gtest/gtest.h>

#include "fixtures.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using master::JobKind;
using master::Outcome;

const rtu::Instant t0{std::chrono::seconds(50)};

master::Result answered() {
    master::Result r;
    r.outcome = Outcome::Ok;
    r.response = rtu::ReadHoldingRegistersResponse{{1, 2, 3, 4, 5}};
    return r;
}

master::Result silent() {
    master::Result r;
    r.outcome = Outcome::Timeout;
    return r;
}

TEST(PlanReads, SplitsWithinTheDrivesLimit) {
    const auto atv21 = load("atv21");
    const auto atv58 = load("atv58");
    // The ATV21 reads one word per plain FC03.
    const auto one_by_one =
        master::plan_reads(poll(*atv21, {"FD00", "FD01"}, 100ms), *atv21, master::limits_of(*atv21));
    ASSERT_EQ(one_by_one.size(), 2U);
    EXPECT_EQ(one_by_one[1].start, 0xFD01);
    // The ATV58 reads consecutive words together, up to 32.
    std::vector<std::string> names;
    for (int i = 450; i <= 459; ++i) {
        names.push_back("W" + std::to_string(i));
    }
    names.push_back("W400");
    const auto merged = master::plan_reads(poll(*atv58, names, 100ms), *atv58, master::limits_of(*atv58));
    ASSERT_EQ(merged.size(), 2U);
    EXPECT_EQ(merged[0].start, 450);
    EXPECT_EQ(merged[0].quantity, 10);
    EXPECT_EQ(merged[1].start, 400);
    // The indirect block: one read at 0x1875 for the five registers.
    const auto block =
        master::plan_reads(poll(*atv21, {"FD00", "FD01", "FE03"}, 100ms, true), *atv21, master::limits_of(*atv21));
    ASSERT_EQ(block.size(), 1U);
    EXPECT_EQ(block[0].start, 0x1875);
    EXPECT_EQ(block[0].quantity, 3);
    EXPECT_EQ(block[0].addresses, (std::vector<std::uint16_t>{0xFD00, 0xFD01, 0xFE03}));
}

class SchedulerTest : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv58 = load("atv58");
    master::BusPlan config = bus();

    void SetUp() override {
        auto a = drive("a", 1, atv58);
        a.polls.push_back(poll(*atv58, {"W450"}, 100ms));
        auto b = drive("b", 2, atv58);
        b.polls.push_back(poll(*atv58, {"W451"}, 100ms));
        config.drives = {a, b};
    }
};

TEST_F(SchedulerTest, PollsAtTheirPeriodsWithoutCatchUpBursts) {
    master::Scheduler s(config, t0);
    auto j1 = s.next(t0);
    ASSERT_TRUE(j1);
    EXPECT_EQ(j1->kind, JobKind::Poll);
    (void)s.complete(*j1, answered(), t0);
    auto j2 = s.next(t0);
    ASSERT_TRUE(j2);
    EXPECT_NE(j2->drive, j1->drive);
    (void)s.complete(*j2, answered(), t0);
    EXPECT_FALSE(s.next(t0 + 50ms));
    EXPECT_EQ(s.next_due(), t0 + 100ms);
    // Half a second late: one cycle each, not five.
    int polls = 0;
    while (auto j = s.next(t0 + 600ms)) {
        (void)s.complete(*j, answered(), t0 + 600ms);
        ++polls;
    }
    EXPECT_EQ(polls, 2);
}

// A cycle's first read carries the time its period made it due, so that lateness can be
// measured against the schedule rather than against the previous cycle.
TEST_F(SchedulerTest, ACyclesFirstReadCarriesItsScheduledTime) {
    master::Scheduler s(config, t0);
    auto j1 = s.next(t0 + 3ms);
    ASSERT_TRUE(j1);
    ASSERT_TRUE(j1->scheduled.has_value());
    (void)s.complete(*j1, answered(), t0 + 4ms);
    auto j2 = s.next(t0 + 4ms);
    ASSERT_TRUE(j2);
    (void)s.complete(*j2, answered(), t0 + 5ms);
    // The next cycle of the first drive, taken 7 ms late, was due one period after the first.
    std::optional<master::Job> next;
    for (auto j = s.next(t0 + 107ms); j; j = s.next(t0 + 107ms)) {
        if (j->drive == j1->drive) {
            next = j;
        }
        (void)s.complete(*j, answered(), t0 + 107ms);
    }
    ASSERT_TRUE(next.has_value());
    ASSERT_TRUE(next->scheduled.has_value());
    EXPECT_EQ(*next->scheduled - *j1->scheduled, 100ms);
}

TEST_F(SchedulerTest, ClientWritesFirstAndFairBetweenClients) {
    master::Scheduler s(config, t0);
    ASSERT_TRUE(s.submit({10, 1, {1, rtu::ReadHoldingRegisters{450, 1}}}).has_value());
    ASSERT_TRUE(s.submit({10, 2, {1, rtu::WriteSingleRegister{400, 1}}}).has_value());
    ASSERT_TRUE(s.submit({10, 3, {1, rtu::WriteSingleRegister{400, 2}}}).has_value());
    ASSERT_TRUE(s.submit({20, 4, {2, rtu::WriteSingleRegister{400, 3}}}).has_value());
    std::vector<std::uint64_t> order;
    while (auto j = s.next(t0)) {
        if (j->kind != JobKind::Client) {
            break;
        }
        order.push_back(j->correlation);
        (void)s.complete(*j, answered(), t0);
    }
    // Writes first, alternating clients 10 and 20, then the read.
    EXPECT_EQ(order, (std::vector<std::uint64_t>{2, 4, 3, 1}));
}

// Client reads go before the polls, but a due poll is taken between two of them: a flood of
// reads delays the polls by one read at most, it cannot starve them.
TEST_F(SchedulerTest, AFloodOfClientReadsDoesNotStarveThePolls) {
    master::Scheduler s(config, t0);
    for (std::uint64_t i = 0; i < 20; ++i) {
        ASSERT_TRUE(s.submit({10 + i % 3, i, {1, rtu::ReadHoldingRegisters{450, 1}}}).has_value());
    }
    std::vector<JobKind> kinds;
    for (int k = 0; k < 8; ++k) {
        auto j = s.next(t0);
        ASSERT_TRUE(j);
        kinds.push_back(j->kind);
        (void)s.complete(*j, answered(), t0);
    }
    // Both drives' polls were due: each went out right after a client read.
    EXPECT_EQ(kinds, (std::vector<JobKind>{JobKind::Client, JobKind::Poll, JobKind::Client, JobKind::Poll,
                                           JobKind::Client, JobKind::Client, JobKind::Client, JobKind::Client}));
}

// A lease fallback has its drive's own slot: taken with every client queue full, sent
// before any client request, one per drive; a line that goes down does not drop it.
TEST_F(SchedulerTest, AFallbackWriteHasItsOwnSlotAheadOfEveryClientQueue) {
    config.queue_limit = 2;
    master::Scheduler s(config, t0);
    ASSERT_TRUE(s.submit({10, 1, {1, rtu::WriteSingleRegister{400, 1}}}).has_value());
    ASSERT_TRUE(s.submit({20, 2, {2, rtu::WriteSingleRegister{400, 2}}}).has_value());
    EXPECT_EQ(s.submit({30, 3, {1, rtu::WriteSingleRegister{400, 3}}}).error(), master::SubmitError::QueueFull);
    master::ClientRequest fallback{0, 99, {2, rtu::WriteSingleRegister{400, 0}}};
    fallback.fallback = true;
    ASSERT_TRUE(s.submit(fallback).has_value()) << "a full client queue must not refuse a fallback";
    fallback.correlation = 100;
    EXPECT_EQ(s.submit(fallback).error(), master::SubmitError::QueueFull) << "one per drive";
    s.line_down(t0);
    EXPECT_EQ(s.take_client_jobs().size(), 2U) << "the clients' requests are answered at line down";
    s.line_up(t0 + 1s);
    const auto first = s.next(t0 + 1s);
    ASSERT_TRUE(first);
    EXPECT_EQ(first->correlation, 99U);
    EXPECT_EQ(first->drive, 1U);
}

// A fallback write silent through every retry marks its drive absent, as a poll would: it is
// retried ahead of the polls, so it may be the only request a silent drive gets (then its
// fallback is given up, rather than retried for ever).
TEST_F(SchedulerTest, ASilentFallbackWriteMarksItsDriveAbsentAndAClientWriteDoesNot) {
    master::Scheduler s(config, t0);
    ASSERT_TRUE(s.submit({10, 1, {2, rtu::WriteSingleRegister{400, 1}}}).has_value());
    auto client = s.next(t0);
    ASSERT_TRUE(client);
    EXPECT_FALSE(client->fallback);
    (void)s.complete(*client, silent(), t0);
    EXPECT_NE(s.health(1), master::Health::Absent) << "a client's time-out says nothing of the drive";
    master::ClientRequest fallback{0, 99, {2, rtu::WriteSingleRegister{400, 0}}};
    fallback.fallback = true;
    ASSERT_TRUE(s.submit(fallback).has_value());
    auto job = s.next(t0 + 1ms);
    ASSERT_TRUE(job);
    EXPECT_TRUE(job->fallback);
    (void)s.complete(*job, silent(), t0 + 1ms);
    EXPECT_EQ(s.health(1), master::Health::Absent);
}

TEST_F(SchedulerTest, AbsentDrivesAreProbedWithDoublingBackOff) {
    config.absent_backoff_min = 1s;
    config.absent_backoff_max = 4s;
    master::Scheduler s(config, t0);
    rtu::Instant now = t0;
    // Drive a never answers.
    auto run_until = [&](rtu::Instant end, std::vector<rtu::Instant>& probes) {
        while (now <= end) {
            if (auto j = s.next(now)) {
                if (j->drive == 0) {
                    if (j->kind == JobKind::Probe) {
                        probes.push_back(now);
                        EXPECT_EQ(j->retries, 0U);
                    }
                    (void)s.complete(*j, silent(), now);
                } else {
                    (void)s.complete(*j, answered(), now);
                }
                continue;
            }
            now += 10ms;
        }
    };
    std::vector<rtu::Instant> probes;
    run_until(t0 + 20s, probes);
    EXPECT_EQ(s.health(0), master::Health::Absent);
    EXPECT_EQ(s.health(1), master::Health::Online);
    ASSERT_GE(probes.size(), 4U);
    EXPECT_EQ(probes[1] - probes[0], 2s);
    EXPECT_EQ(probes[2] - probes[1], 4s);
    EXPECT_EQ(probes[3] - probes[2], 4s);  // capped
    EXPECT_EQ(s.snapshot(0).counters.absent_transitions, 1U);
}

}  // namespace
}  // namespace drivebus::test
