// SPDX-License-Identifier: Apache-2.0
// A client request's deadline on the virtual line: one that passes while the request waits
// behind a slow drive is answered Expired at its deadline and never reaches the wire; one that
// is met is sent as any other.
#include <gtest/gtest.h>

#include <algorithm>

#include "fixtures.hpp"
#include "master/finished.hpp"
#include "sim_fixture.hpp"
#include "virtual_line.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

const rtu::Instant kStart{std::chrono::seconds(100)};

class DeadlineTest : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");
    std::shared_ptr<const Profile> atv58 = load("atv58");
    master::BusPlan config = bus();
    rtu::CharacterTiming timing = rtu::character_timing(config.format).value();
    std::vector<std::pair<std::uint64_t, master::Result>> results;
    std::vector<rtu::Instant> answered_at;
    std::unique_ptr<master::BusEngine> engine;
    sim::Bus drives{{timing, 1ms, true, 3}};
    std::unique_ptr<VirtualLine> line;

    // The pump answers 60 ms late, past the 50 ms response time-out: each of its transactions
    // takes all its attempts. The fan answers in time.
    void SetUp() override {
        auto pump = drive("pump", 1, atv21);
        pump.polls.push_back(poll(*atv21, {"FD00"}, 20ms));
        config.drives.push_back(pump);
        drives.add(sim::make_drive(1, atv21));
        ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
        ASSERT_TRUE(drives.faults().apply(1, "late=60ms").has_value());
        auto fan = drive("fan", 2, atv58);
        fan.polls.push_back(poll(*atv58, {"W450"}, 1s));
        config.drives.push_back(fan);
        drives.add(sim::make_drive(2, atv58));
        master::EngineCallbacks callbacks;
        callbacks.client_result = [this](std::uint64_t id, const master::Result& r) {
            results.emplace_back(id, r);
            answered_at.push_back(line->now());
        };
        engine = std::make_unique<master::BusEngine>(config, timing, callbacks, kStart);
        engine->line_up(kStart);
        line = std::make_unique<VirtualLine>(*engine, drives, timing, kStart);
    }

    [[nodiscard]] bool on_the_wire(std::uint8_t address, std::uint16_t reg) const {
        return std::ranges::any_of(line->transmissions(), [&](const VirtualLine::Transmission& t) {
            return t.adu.size() >= 4 && t.adu[0] == address && t.adu[1] == 6 && t.adu[2] == (reg >> 8) &&
                   t.adu[3] == (reg & 0xFF);
        });
    }
    [[nodiscard]] const master::Result* result_of(std::uint64_t id) const {
        const auto it = std::ranges::find(results, id, &std::pair<std::uint64_t, master::Result>::first);
        return it == results.end() ? nullptr : &it->second;
    }
};

TEST_F(DeadlineTest, AWriteWhoseDeadlinePassesBehindASlowDriveIsAnsweredExpiredAndNeverSent) {
    line->run_for(10ms);  // the pump's first poll is on the line, and will take all its attempts
    const auto submitted = line->now();
    master::ClientRequest late{7, 1, {2, rtu::WriteSingleRegister{401, 1234}}};
    late.deadline = submitted + 30ms;
    ASSERT_TRUE(engine->submit(late).has_value());
    master::ClientRequest met{8, 2, {2, rtu::WriteSingleRegister{400, 3}}};
    met.deadline = submitted + 5s;
    ASSERT_TRUE(engine->submit(met).has_value());
    line->run_for(2s);
    const auto* expired = result_of(1);
    ASSERT_NE(expired, nullptr);
    EXPECT_EQ(expired->outcome, master::Outcome::Expired);
    EXPECT_TRUE(expired->unsent);
    EXPECT_EQ(master::finished(1, *expired).refusal, master::Refusal::Expired);
    // Answered at its deadline, not when the slow transaction ahead of it ended.
    const auto at = answered_at[static_cast<std::size_t>(
        std::ranges::find(results, 1U, [](const auto& r) { return r.first; }) - results.begin())];
    EXPECT_EQ(at, submitted + 30ms);
    EXPECT_FALSE(on_the_wire(2, 401)) << "sent after its deadline";
    EXPECT_NE(drives.drive(2)->peek("W401").value(), 1234);
    // The other, with time to spare, went out when the line was free.
    const auto* sent = result_of(2);
    ASSERT_NE(sent, nullptr);
    EXPECT_EQ(sent->outcome, master::Outcome::Ok);
    EXPECT_TRUE(on_the_wire(2, 400));
    EXPECT_EQ(drives.drive(2)->peek("W400").value(), 3);
    EXPECT_EQ(engine->scheduler().queued(), 0U);
}

// A read queued behind the slow pump with its client's give-up time as deadline: the client's
// time-out bounds its answer, however many slow transactions are ahead of it.
TEST_F(DeadlineTest, QueuedReadsAreAnsweredByTheirDeadlineWhateverIsAheadOfThem) {
    line->run_for(10ms);
    const auto submitted = line->now();
    for (std::uint64_t i = 1; i <= 20; ++i) {
        master::ClientRequest read{9, i, {1, rtu::ReadHoldingRegisters{0xFD00, 1}}};
        read.deadline = submitted + 400ms;
        ASSERT_TRUE(engine->submit(read).has_value());
    }
    line->run_for(5s);
    ASSERT_EQ(results.size(), 20U);
    std::size_t expired = 0;
    for (std::size_t i = 0; i < results.size(); ++i) {
        if (results[i].second.outcome == master::Outcome::Expired) {
            ++expired;
            EXPECT_EQ(answered_at[i], submitted + 400ms) << "answered after its client gave up";
        } else {
            // Sent before the deadline: it ends with the one transaction it was in.
            EXPECT_LT(answered_at[i] - submitted, 400ms + 1s);
        }
    }
    // Each pump transaction takes three attempts of 50 ms and more: most never went out.
    EXPECT_GE(expired, 15U);
    EXPECT_EQ(engine->scheduler().queued(), 0U);
}

}  // namespace
}  // namespace drivebus::test
