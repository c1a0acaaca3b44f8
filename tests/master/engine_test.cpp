// SPDX-License-Identifier: Apache-2.0
// The master on a virtual line against simulated drives: polling, the t3.5 rule, the
// indirect block, every simulator fault, absent drives, clients, broadcasts, keep-alive.
#include <gtest/gtest.h>

#include <algorithm>

#include "atv21.hpp"
#include "fixtures.hpp"
#include "sim_fixture.hpp"
#include "virtual_line.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using master::Health;

const rtu::Instant kStart{std::chrono::seconds(100)};

class EngineTest : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");
    std::shared_ptr<const Profile> atv58 = load("atv58");
    master::BusPlan config = bus();
    rtu::CharacterTiming timing = rtu::character_timing(config.format).value();
    std::vector<master::DriveSnapshot> snapshots;
    std::vector<std::pair<std::uint64_t, master::Result>> client_results;
    std::unique_ptr<master::BusEngine> engine;
    sim::Bus drives{{timing, 1ms, true, 3}};
    std::unique_ptr<VirtualLine> line;

    void add_pump(bool indirect = false) {
        auto d = drive("pump", 1, atv21);
        if (indirect) {
            d.polls.push_back(poll(*atv21, {"FD00", "FD01", "FE03", "FE05", "FC91"}, 100ms, true));
        } else {
            d.polls.push_back(poll(*atv21, {"FD00", "FD01"}, 100ms));
        }
        d.keep_alive = 1s;
        config.drives.push_back(d);
        drives.add(sim::make_drive(1, atv21));
    }
    void add_fan() {
        auto d = drive("fan", 2, atv58);
        d.polls.push_back(
            poll(*atv58, {"W450", "W451", "W452", "W453", "W454", "W455", "W456", "W457", "W458", "W459"}, 200ms));
        config.drives.push_back(d);
        drives.add(sim::make_drive(2, atv58));
    }
    void start() {
        master::EngineCallbacks callbacks;
        callbacks.snapshot = [this](const master::DriveSnapshot& s) { snapshots.push_back(s); };
        callbacks.client_result = [this](std::uint64_t id, const master::Result& r) {
            client_results.emplace_back(id, r);
        };
        engine = std::make_unique<master::BusEngine>(config, timing, callbacks, kStart);
        engine->line_up(kStart);
        line = std::make_unique<VirtualLine>(*engine, drives, timing, kStart);
    }
    // The latest snapshot of a drive (throws, failing the test, when there is none).
    [[nodiscard]] const master::DriveSnapshot& last(const std::string& name) const {
        for (auto it = snapshots.rbegin(); it != snapshots.rend(); ++it) {
            if (it->name == name) {
                return *it;
            }
        }
        throw std::runtime_error("no snapshot of " + name);
    }
    [[nodiscard]] std::size_t transmissions_to(std::uint8_t address, rtu::Instant from, rtu::Instant to) const {
        std::size_t n = 0;
        for (const auto& t : line->transmissions()) {
            n += (t.adu[0] == address && t.start >= from && t.start < to) ? 1U : 0U;
        }
        return n;
    }
    void expect_silences_kept() const {
        for (const auto& t : line->transmissions()) {
            ASSERT_GE(t.start - t.prior_activity, timing.t3_5) << "a request started too early";
        }
    }
};

TEST_F(EngineTest, PollsBothDrivesAndReturnsTheirValues) {
    add_pump();
    add_fan();
    ASSERT_TRUE(drives.drive(2)->poke("W453", 1234).has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W459", 65535).has_value());
    ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
    start();
    line->run_for(1s);
    const auto& fan = last("fan");
    EXPECT_EQ(fan.health, Health::Online);
    EXPECT_EQ(fan.registers.at(453).value, 1234);
    EXPECT_EQ(fan.registers.at(459).value, 65535);
    EXPECT_TRUE(fan.registers.at(459).valid);
    const auto& pump = last("pump");
    EXPECT_TRUE(pump.registers.at(0xFD01).valid);
    EXPECT_EQ(pump.registers.at(0xFD01).value, drives.drive(1)->peek("FD01").value());
    // 100 ms and 200 ms periods over one second.
    EXPECT_GE(std::ranges::count_if(snapshots, [](const auto& s) { return s.name == "pump"; }), 9);
    EXPECT_GE(std::ranges::count_if(snapshots, [](const auto& s) { return s.name == "fan"; }), 4);
    expect_silences_kept();
    EXPECT_EQ(engine->status().counters.timeouts, 0U);
}

TEST_F(EngineTest, TheFirstRequestAfterLineUpAddsNoExtraGap) {
    add_fan();
    start();
    line->run_for(1s);
    const auto& gap = engine->status().extra_gap;
    EXPECT_GT(gap.count, 0U);
    // Before the first request nothing was on the line: no silence to measure (not the time
    // since the clock's epoch).
    EXPECT_LT(gap.max, 1s);
    EXPECT_LT(gap.count, engine->status().counters.transmissions);
}

// What the bus thread's send_spin relies on: next_send_at() is unknown while a frame is open,
// and is the first instant at which transmission() gives a request: t3.5 after the last
// character (the framer closes a frame by silence one character later, to be sure of it).
TEST_F(EngineTest, NextSendAtIsTheFirstInstantTransmissionHasARequest) {
    add_fan();
    config.drives.back().polls.back().period = 1ms;  // always due
    engine = std::make_unique<master::BusEngine>(config, timing, master::EngineCallbacks{}, kStart);
    engine->line_up(kStart);
    const rtu::Instant noise = kStart + 10ms;
    const std::array<std::uint8_t, 1> byte{0x55};
    engine->on_bytes(byte, noise);
    EXPECT_FALSE(engine->next_send_at().has_value()) << "a frame is open";
    EXPECT_FALSE(engine->transmission(noise + timing.t3_5).has_value()) << "a frame is open";
    const auto closes = engine->framer().deadline();
    ASSERT_TRUE(closes.has_value());
    engine->on_time(*closes);
    ASSERT_FALSE(engine->framer().frame_open());
    const auto at = engine->next_send_at();
    ASSERT_TRUE(at.has_value());
    EXPECT_EQ(*at, noise + timing.t3_5);
    EXPECT_EQ(*at, engine->line_free_at());
    EXPECT_FALSE(engine->transmission(*at - 1ns).has_value());
    const auto adu = engine->transmission(*at);
    ASSERT_TRUE(adu.has_value());
    EXPECT_EQ((*adu)[0], 2);
    engine->written(*at);
    EXPECT_FALSE(engine->next_send_at().has_value()) << "one request at a time";
}

TEST_F(EngineTest, KeepsTheSilenceAndNoMoreWhenTheLineIsBusy) {
    add_fan();
    config.drives.back().polls.back().period = 1ms;  // always due: the line is saturated
    start();
    line->run_for(500ms);
    ASSERT_GT(line->transmissions().size(), 10U);
    expect_silences_kept();
    // On a virtual line the engine starts each request exactly at the earliest allowed moment
    // (the first one has no line activity before it).
    const auto& sent = line->transmissions();
    for (std::size_t i = 1; i < sent.size(); ++i) {
        EXPECT_EQ(sent[i].start, sent[i].free_at) << i;
        EXPECT_EQ(sent[i].start, sent[i].prior_activity + timing.t3_5) << i;
    }
}

// The ATV21 applies F875-F879 after a reset (guide section 6). Fresh from the factory they are 0:
// each is read, written and read back; the block then still returns the old selection (every
// slot 0, while FD01 reads "ready"), so the drive awaits a reset: published as such, values
// invalid, its block never polled and refused to clients. Switched off and on, its block
// returns what the selectors choose, told apart from the old selection, and it is polled in
// one transaction.
TEST_F(EngineTest, IndirectBlockIsSetUpConfirmedAfterAResetThenReadInOneTransaction) {
    add_pump(true);
    start();
    ASSERT_TRUE(
        line->run_until_true([&] { return !snapshots.empty() && last("pump").health == Health::AwaitingReset; }, 2s));
    const auto& sent = line->transmissions();
    ASSERT_GE(sent.size(), 15U);
    // F875-F879 are read, written with the choices for FD00, FD01, FE03, FE05, FC91, read back.
    const std::vector<std::uint16_t> choices{2, 1, 3, 4, 5};
    for (std::size_t i = 0; i < 5; ++i) {
        EXPECT_EQ(sent[3 * i].adu[1], 0x03);
        EXPECT_EQ(sent[3 * i + 1].adu[1], 0x06);
        EXPECT_EQ(sent[3 * i + 2].adu[1], 0x03);
        EXPECT_EQ(sent[3 * i].adu[3], 0x75 + i);
        EXPECT_EQ(sent[3 * i + 1].adu[3], sent[3 * i].adu[3]);
        EXPECT_EQ(sent[3 * i + 2].adu[3], sent[3 * i].adu[3]) << "the selector just written is read back";
        EXPECT_EQ(drives.drive(1)->peek("F87" + std::to_string(5 + i)).value(), choices[i]);
    }
    const auto& waiting = last("pump");
    EXPECT_EQ(waiting.setup.kind, master::SetupNote::Kind::BlockDiffers);
    EXPECT_EQ(waiting.setup.slot, 2);  // FD01: "ready" directly, 0 through the block
    EXPECT_EQ(waiting.setup.reg, 0xFD01);
    EXPECT_EQ(waiting.setup.held, 0);
    for (const auto& [address, v] : waiting.registers) {
        EXPECT_FALSE(v.valid) << "register " << address;
    }
    master::ClientRequest through_block;
    through_block.client = 7;
    through_block.correlation = 1;
    through_block.request = {1, rtu::ReadHoldingRegisters{0x1875, 5}};
    EXPECT_EQ(engine->submit(through_block).error(), master::SubmitError::BlockUnconfirmed);
    // No poll while it waits: only the set-up, tried again with back-off, reads the block.
    line->run_for(3s);
    EXPECT_EQ(last("pump").health, Health::AwaitingReset);
    const std::size_t before_reset = sent.size();

    drives.drive(1)->power_cycle(line->now());
    ASSERT_TRUE(line->run_until_true([&] { return last("pump").health == Health::Online; }, 70s));
    for (std::size_t i = before_reset; i < sent.size(); ++i) {
        EXPECT_NE(sent[i].adu[1], 0x06) << "nothing is written again: the selectors hold";
    }
    line->run_for(500ms);
    const auto& pump = last("pump");
    EXPECT_EQ(pump.registers.at(0xFD01).value, drives.drive(1)->peek("FD01").value());
    EXPECT_NE(pump.registers.at(0xFD01).value, 0);
    EXPECT_TRUE(pump.registers.at(0xFC91).valid);
    EXPECT_EQ(sent.back().adu[1], 0x03);
    EXPECT_TRUE(engine->submit(through_block).has_value());
    expect_silences_kept();
}

// drivebusd restarted on a drive it set up before: every selector already holds, so nothing is
// written (the drive keeps them in EEPROM), and the block is confirmed and polled at once.
TEST_F(EngineTest, SelectorsThatAlreadyHoldAreNotWrittenAgain) {
    add_pump(true);
    const std::vector<std::uint16_t> choices{2, 1, 3, 4, 5};
    for (std::size_t i = 0; i < 5; ++i) {
        ASSERT_TRUE(drives.drive(1)->poke("F87" + std::to_string(5 + i), choices[i]).has_value());
    }
    drives.drive(1)->power_cycle(kStart);
    start();
    ASSERT_TRUE(line->run_until_true([&] { return !snapshots.empty() && last("pump").health == Health::Online; }, 2s));
    line->run_for(300ms);
    for (const auto& t : line->transmissions()) {
        EXPECT_NE(t.adu[1], 0x06);
    }
    EXPECT_EQ(last("pump").registers.at(0xFD01).value, drives.drive(1)->peek("FD01").value());
}

// drivebusd restarted after writing the selectors, and the drive not reset since: the
// selectors read as wanted, but the block returns the old selection. Unconfigured, said why.
TEST_F(EngineTest, SelectorsStoredButNotAppliedLeaveTheDriveUnconfigured) {
    add_pump(true);
    const std::vector<std::uint16_t> choices{2, 1, 3, 4, 5};
    for (std::size_t i = 0; i < 5; ++i) {
        ASSERT_TRUE(drives.drive(1)->poke("F87" + std::to_string(5 + i), choices[i]).has_value());
    }
    start();
    ASSERT_TRUE(
        line->run_until_true([&] { return !snapshots.empty() && last("pump").health == Health::Unconfigured; }, 2s));
    EXPECT_EQ(last("pump").setup.kind, master::SetupNote::Kind::BlockDiffers);
    // Switched off and on, it applies them: the next try confirms the block.
    drives.drive(1)->power_cycle(line->now());
    ASSERT_TRUE(line->run_until_true([&] { return last("pump").health == Health::Online; }, 70s));
}

// A drive switched off and on while polled (silent, then answering again) has its set-up read
// again and its block confirmed before anything read through it is published.
TEST_F(EngineTest, ADriveBackFromAbsenceHasItsBlockConfirmedAgain) {
    add_pump(true);
    start();
    ASSERT_TRUE(
        line->run_until_true([&] { return !snapshots.empty() && last("pump").health == Health::AwaitingReset; }, 2s));
    drives.drive(1)->power_cycle(line->now());
    ASSERT_TRUE(line->run_until_true([&] { return last("pump").health == Health::Online; }, 70s));
    ASSERT_TRUE(drives.faults().apply(1, "drop=1").has_value());
    ASSERT_TRUE(line->run_until_true([&] { return last("pump").health == Health::Absent; }, 5s));
    drives.drive(1)->power_cycle(line->now());
    drives.faults().clear(std::nullopt);
    const std::size_t back_from = line->transmissions().size();
    ASSERT_TRUE(line->run_until_true(
        [&] { return last("pump").health == Health::Online && last("pump").registers.at(0xFD01).valid; }, 70s));
    // The selectors were read again and the block read on its own terms before the polls.
    std::size_t selector_reads = 0;
    std::size_t direct_fd01 = 0;
    for (std::size_t i = back_from; i < line->transmissions().size(); ++i) {
        const auto& adu = line->transmissions()[i].adu;
        selector_reads += adu[1] == 0x03 && adu[2] == 0x08 && adu[3] >= 0x75 && adu[3] <= 0x79 ? 1U : 0U;
        direct_fd01 += adu[1] == 0x03 && adu[2] == 0xFD && adu[3] == 0x01 ? 1U : 0U;
    }
    EXPECT_GE(selector_reads, 5U);
    EXPECT_GE(direct_fd01, 1U);
    EXPECT_EQ(last("pump").registers.at(0xFD01).value, drives.drive(1)->peek("FD01").value());
}

// A reset after a fault makes the ATV21 apply what it stores: when the polled status word's
// fault bit clears, drivebusd reads the selectors and confirms the block again.
TEST_F(EngineTest, AFaultClearedHasTheBlockConfirmedAgain) {
    add_pump(true);
    const std::vector<std::uint16_t> choices{2, 1, 3, 4, 5};
    for (std::size_t i = 0; i < 5; ++i) {
        ASSERT_TRUE(drives.drive(1)->poke("F87" + std::to_string(5 + i), choices[i]).has_value());
    }
    ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
    drives.drive(1)->power_cycle(kStart);
    start();
    ASSERT_TRUE(line->run_until_true([&] { return !snapshots.empty() && last("pump").health == Health::Online; }, 2s));
    ASSERT_TRUE(engine->submit({7, 1, {1, rtu::WriteSingleRegister{0xFA00, 0xC000 | (1U << 12)}}}).has_value());
    ASSERT_TRUE(line->run_until_true([&] { return (last("pump").registers.at(0xFD01).value & 0x2U) != 0; }, 2s));
    const std::size_t before_reset = line->transmissions().size();
    ASSERT_TRUE(engine->submit({7, 2, {1, rtu::WriteSingleRegister{0xFA00, 0xC000 | (1U << 13)}}}).has_value());
    ASSERT_TRUE(line->run_until_true([&] { return (last("pump").registers.at(0xFD01).value & 0x2U) == 0; }, 2s));
    line->run_for(500ms);
    std::size_t selector_reads = 0;
    for (std::size_t i = before_reset; i < line->transmissions().size(); ++i) {
        const auto& adu = line->transmissions()[i].adu;
        selector_reads += adu[1] == 0x03 && adu[2] == 0x08 && adu[3] >= 0x75 && adu[3] <= 0x79 ? 1U : 0U;
    }
    EXPECT_EQ(selector_reads, 5U) << "the selectors read once after the fault cleared";
    EXPECT_EQ(last("pump").health, Health::Online);
    EXPECT_EQ(last("pump").registers.at(0xFD01).value, drives.drive(1)->peek("FD01").value());
}

// A set-up read the drive refuses leaves it unconfigured: published as such, not polled (its
// block would return what the old selectors choose), and set up again with back-off until it
// holds.
TEST_F(EngineTest, ADriveWhoseSetUpFailsIsUnconfiguredUntilItHolds) {
    add_pump(true);
    const std::vector<std::uint16_t> choices{2, 1, 3, 4, 5};
    for (std::size_t i = 0; i < 5; ++i) {
        ASSERT_TRUE(drives.drive(1)->poke("F87" + std::to_string(5 + i), choices[i]).has_value());
    }
    drives.drive(1)->power_cycle(kStart);
    ASSERT_TRUE(drives.faults().apply(1, "exception=4").has_value());
    start();
    line->run_for(500ms);
    ASSERT_FALSE(snapshots.empty());
    const auto& failed = last("pump");
    EXPECT_EQ(failed.health, master::Health::Unconfigured);
    EXPECT_EQ(failed.setup.kind, master::SetupNote::Kind::Refused);
    EXPECT_EQ(failed.setup.exception, 4);
    for (const auto& [address, v] : failed.registers) {
        EXPECT_FALSE(v.valid) << "register " << address;
    }
    for (const auto& t : line->transmissions()) {
        EXPECT_FALSE(t.adu[1] == 0x03 && t.adu[2] == 0x18) << "the block was read before its set-up held";
    }
    drives.faults().clear(std::nullopt);
    line->run_for(3s);
    const auto& pump = last("pump");
    EXPECT_EQ(pump.health, master::Health::Online);
    EXPECT_TRUE(pump.registers.at(0xFC91).valid);
    EXPECT_EQ(pump.registers.at(0xFD01).value, drives.drive(1)->peek("FD01").value());
}

TEST_F(EngineTest, CorruptedRepliesAreNeverAccepted) {
    add_fan();
    ASSERT_TRUE(drives.drive(2)->poke("W450", 111).has_value());
    start();
    line->run_for(300ms);
    ASSERT_EQ(last("fan").registers.at(450).value, 111);
    ASSERT_TRUE(drives.faults().apply(2, "crc=1").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W450", 222).has_value());
    snapshots.clear();
    line->run_for(1s);
    for (const auto& s : snapshots) {
        EXPECT_NE(s.registers.at(450).value, 222) << "a value from a corrupted reply was accepted";
    }
    EXPECT_GT(engine->status().counters.crc_errors, 0U);
    EXPECT_GT(engine->status().counters.retries, 0U);
    drives.faults().clear(std::nullopt);
    line->run_for(2s);
    EXPECT_EQ(last("fan").registers.at(450).value, 222);
    expect_silences_kept();
}

TEST_F(EngineTest, AbsentDriveDoesNotDelayTheOther) {
    add_pump();
    add_fan();
    ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
    start();
    line->run_for(1s);
    const auto before = transmissions_to(2, kStart, kStart + 1s);
    ASSERT_TRUE(drives.faults().apply(1, "drop=1").has_value());
    line->run_for(5s);
    EXPECT_EQ(last("pump").health, Health::Absent);
    EXPECT_FALSE(last("pump").registers.at(0xFD00).valid);
    EXPECT_EQ(last("pump").counters.absent_transitions, 1U);
    // The fan is polled at its rate: one cycle (one transaction) per 200 ms.
    const auto during = transmissions_to(2, kStart + 2s, kStart + 6s);
    EXPECT_GE(during, 4 * before - 2);
    // Probes back off: 1 s, 2 s, 4 s ...
    const auto probes = transmissions_to(1, kStart + 2s, kStart + 6s);
    EXPECT_LE(probes, 3U);
    drives.faults().clear(std::nullopt);
    line->run_for(10s);
    EXPECT_EQ(last("pump").health, Health::Online);
    expect_silences_kept();
}

TEST_F(EngineTest, ExceptionsAreResultsNotValues) {
    add_fan();
    ASSERT_TRUE(drives.faults().apply(2, "exception=4").has_value());
    start();
    line->run_for(500ms);
    EXPECT_GT(engine->status().counters.exceptions[4], 0U);
    for (const auto& s : snapshots) {
        EXPECT_FALSE(s.registers.at(450).valid);
    }
    EXPECT_EQ(engine->status().counters.retries, 0U);  // an exception is an answer
}

TEST_F(EngineTest, NoiseAndGapsAreSurvived) {
    add_fan();
    config.delivery_allowance = rtu::Duration{0};  // the wire bound alone
    ASSERT_TRUE(drives.drive(2)->poke("W451", 51).has_value());
    // Noise then a 2-character silence: the reply is still found.
    ASSERT_TRUE(drives.faults().apply(2, "noise=2:2").has_value());
    start();
    line->run_for(500ms);
    EXPECT_EQ(last("fan").registers.at(451).value, 51);
    // A silence inside every reply that the reply's wire bound still allows (its characters
    // end no more than t3.5 later than back to back): what a delivery held back by the kernel
    // looks like. The reply is complete and its CRC good: accepted, counted as held.
    ASSERT_TRUE(drives.faults().apply(2, "noise=0").has_value());
    ASSERT_TRUE(drives.faults().apply(2, "gap=5:2.5").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W451", 52).has_value());
    line->run_for(500ms);
    EXPECT_EQ(last("fan").registers.at(451).value, 52);
    EXPECT_GT(engine->status().counters.held_replies, 0U);
    // A longer silence cannot be a late delivery of a reply on time: no value accepted, every
    // attempt counted.
    ASSERT_TRUE(drives.faults().apply(2, "gap=5:4").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W451", 53).has_value());
    snapshots.clear();
    line->run_for(500ms);
    EXPECT_GT(engine->status().counters.gap_errors, 0U);
    for (const auto& s : snapshots) {
        EXPECT_NE(s.registers.at(451).value, 53);
    }
    expect_silences_kept();
}

// With the delivery allowance (50 ms by default) a silence on the wire inside a reply cannot be
// told from a delivery held back: a good reply is taken (its CRC and length say it is whole).
// A silence longer than the allowance still spoils it.
TEST_F(EngineTest, ASilenceWithinTheDeliveryAllowanceIsTakenAsAHeldDelivery) {
    add_fan();
    ASSERT_TRUE(drives.faults().apply(2, "gap=5:4").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W451", 61).has_value());
    start();
    line->run_for(500ms);
    EXPECT_EQ(last("fan").registers.at(451).value, 61);
    EXPECT_GT(engine->status().counters.held_replies, 0U);
    EXPECT_EQ(engine->status().counters.gap_errors, 0U);
    // 100 characters at 19200 bit/s: 57 ms, past the bound + 50 ms.
    ASSERT_TRUE(drives.faults().apply(2, "gap=5:100").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W451", 62).has_value());
    snapshots.clear();
    line->run_for(1s);
    EXPECT_GT(engine->status().counters.gap_errors, 0U);
    for (const auto& s : snapshots) {
        EXPECT_NE(s.registers.at(451).value, 62);
    }
    expect_silences_kept();
}

TEST_F(EngineTest, LateRepliesAreNotMistakenForTheNextOne) {
    add_pump();
    add_fan();
    ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
    // Drive 1 answers after 60 ms, past the 50 ms response timeout: its replies arrive late.
    ASSERT_TRUE(drives.faults().apply(1, "late=60ms").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W450", 450).has_value());
    start();
    line->run_for(2s);
    EXPECT_GT(engine->status().counters.timeouts, 0U);
    for (const auto& s : snapshots) {
        if (s.name == "fan") {
            for (const auto& [address, v] : s.registers) {
                if (v.valid && address == 450) {
                    EXPECT_EQ(v.value, 450);
                }
            }
        }
    }
    EXPECT_EQ(last("fan").health, Health::Online);
    expect_silences_kept();
}

TEST_F(EngineTest, EchoIsConsumedAndChecked) {
    add_fan();
    config.echo = master::EchoMode::On;
    ASSERT_TRUE(drives.faults().apply(0, "echo=1").has_value());
    ASSERT_TRUE(drives.drive(2)->poke("W452", 4242).has_value());
    start();
    line->run_for(500ms);
    EXPECT_EQ(last("fan").registers.at(452).value, 4242);
    EXPECT_EQ(engine->status().counters.echo_mismatches, 0U);
    EXPECT_EQ(engine->status().counters.foreign, 0U);
}

TEST_F(EngineTest, EchoAutoDetection) {
    add_fan();
    config.echo = master::EchoMode::Auto;
    ASSERT_TRUE(drives.faults().apply(0, "echo=1").has_value());
    start();
    line->run_for(300ms);
    EXPECT_EQ(engine->echo(), master::EchoSetting::On);
    EXPECT_TRUE(last("fan").registers.at(450).valid);
}

TEST_F(EngineTest, EchoAutoDetectsNoEcho) {
    add_fan();
    config.echo = master::EchoMode::Auto;
    start();
    line->run_for(300ms);
    EXPECT_EQ(engine->echo(), master::EchoSetting::Off);
    EXPECT_TRUE(last("fan").registers.at(450).valid);
}

TEST_F(EngineTest, ClientWritesGoFirstAndBroadcastsWaitTheTurnaround) {
    add_pump();
    add_fan();
    ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
    config.broadcast_turnaround = 20ms;
    start();
    line->run_for(50ms);
    ASSERT_TRUE(engine->submit({7, 1, {2, rtu::ReadHoldingRegisters{450, 1}}}).has_value());
    ASSERT_TRUE(engine->submit({7, 2, {1, rtu::WriteSingleRegister{0xFA01, 3000}}}).has_value());
    ASSERT_TRUE(engine->submit({8, 3, {0, rtu::WriteSingleRegister{401, 99}}}).has_value());
    line->run_for(500ms);
    ASSERT_EQ(client_results.size(), 3U);
    // Writes first, round-robin between clients: 7's write, 8's broadcast, then 7's read.
    EXPECT_EQ(client_results[0].first, 2U);
    EXPECT_EQ(client_results[1].first, 3U);
    EXPECT_EQ(client_results[2].first, 1U);
    EXPECT_EQ(drives.drive(1)->peek("FA01").value(), 3000);
    EXPECT_EQ(drives.drive(2)->peek("W401").value(), 99);
    // After the broadcast, the next request waited the turnaround.
    const auto& sent = line->transmissions();
    for (std::size_t i = 0; i + 1 < sent.size(); ++i) {
        if (sent[i].adu[0] == 0) {
            const auto tx_end = sent[i].start + timing.character * static_cast<std::int64_t>(sent[i].adu.size());
            EXPECT_GE(sent[i + 1].start - tx_end, 20ms);
        }
    }
}

TEST_F(EngineTest, QueueLimitRejects) {
    add_fan();
    config.queue_limit = 2;
    start();
    EXPECT_TRUE(engine->submit({1, 1, {2, rtu::ReadHoldingRegisters{450, 1}}}).has_value());
    EXPECT_TRUE(engine->submit({1, 2, {2, rtu::ReadHoldingRegisters{450, 1}}}).has_value());
    EXPECT_EQ(engine->submit({1, 3, {2, rtu::ReadHoldingRegisters{450, 1}}}).error(), master::SubmitError::QueueFull);
    EXPECT_EQ(engine->submit({1, 4, {9, rtu::ReadHoldingRegisters{450, 1}}}).error(),
              master::SubmitError::UnknownDrive);
    EXPECT_EQ(engine->status().counters.queue_rejections, 1U);
}

TEST_F(EngineTest, KeepAliveHoldsOffTheModbusTimeout) {
    // A drive with nothing to poll still gets a request every second (F803 is 3 s).
    auto d = drive("idle", 1, atv21);
    d.keep_alive = 1s;
    config.drives.push_back(d);
    drives.add(sim::make_drive(1, atv21));
    start();
    line->run_for(10s);
    EXPECT_EQ(drives.drive(1)->peek("FC90").value(), 0);
    EXPECT_GE(line->transmissions().size(), 9U);
}

TEST_F(EngineTest, WithoutKeepAliveTheDriveTrips) {
    auto d = drive("idle", 1, atv21);
    d.polls.push_back(poll(*atv21, {"FD00"}, 5s));
    config.drives.push_back(d);
    drives.add(sim::make_drive(1, atv21));
    start();
    line->run_for(12s);
    EXPECT_EQ(drives.drive(1)->peek("FC90").value(), sim::Atv21Drive::kFaultModbusTimeout);
}

TEST_F(EngineTest, LineDownAndUp) {
    add_fan();
    start();
    line->run_for(300ms);
    engine->line_down(line->now());
    EXPECT_FALSE(engine->up());
    const auto sent = line->transmissions().size();
    line->run_for(1s);
    EXPECT_EQ(line->transmissions().size(), sent);
    engine->line_up(line->now());
    line->run_for(500ms);
    EXPECT_GT(line->transmissions().size(), sent);
    EXPECT_EQ(engine->status().counters.line_down, 1U);
}

}  // namespace
}  // namespace drivebus::test
