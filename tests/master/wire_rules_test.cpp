// SPDX-License-Identifier: Apache-2.0
// The master's wire rules when the kernel hands bytes over late and when drives answer late:
// a reply held back is still the reply if it completes within its wire bound, a retry never
// starts before a begun reply can have ended, bytes waiting to be read delay the write, and a
// reply that comes after its time-out is never taken for the answer to another request.
#include <gtest/gtest.h>

#include <map>

#include "fixtures.hpp"
#include "sim_fixture.hpp"
#include "virtual_line.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

const rtu::Instant kStart{std::chrono::seconds(100)};

// The fan: an Altivar 58 at address 2 whose 10-register poll is a 25-byte reply.
constexpr std::size_t kFanReply = 25;

class WireRules : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");
    std::shared_ptr<const Profile> atv58 = load("atv58");
    master::BusPlan config = bus();
    rtu::CharacterTiming timing = rtu::character_timing(config.format).value();
    std::vector<master::DriveSnapshot> snapshots;
    std::vector<std::pair<std::uint64_t, master::Result>> results;
    std::unique_ptr<master::BusEngine> engine;
    sim::Bus drives{{timing, 1ms, true, 3}};
    std::unique_ptr<VirtualLine> line;
    rtu::Instant held_reply_first_{};  // the end of the held reply's first character on the wire

    void add_fan(rtu::Duration period = 50ms) {
        auto d = drive("fan", 2, atv58);
        d.polls.push_back(
            poll(*atv58, {"W450", "W451", "W452", "W453", "W454", "W455", "W456", "W457", "W458", "W459"}, period));
        config.drives.push_back(d);
        drives.add(sim::make_drive(2, atv58));
        for (int i = 0; i < 10; ++i) {
            ASSERT_TRUE(drives.drive(2)->poke("W45" + std::to_string(i), static_cast<std::uint16_t>(4500 + i)));
        }
    }
    void start() {
        master::EngineCallbacks callbacks;
        callbacks.snapshot = [this](const master::DriveSnapshot& s) { snapshots.push_back(s); };
        callbacks.client_result = [this](std::uint64_t id, const master::Result& r) { results.emplace_back(id, r); };
        engine = std::make_unique<master::BusEngine>(config, timing, callbacks, kStart);
        engine->line_up(kStart);
        line = std::make_unique<VirtualLine>(*engine, drives, timing, kStart);
    }
    // Every value any snapshot carries as valid is the drive's own.
    void expect_fan_values_right() const {
        std::size_t checked = 0;
        for (const auto& s : snapshots) {
            for (const auto& [address, v] : s.registers) {
                if (v.valid) {
                    EXPECT_EQ(v.value, 4500 + (address - 450)) << "W" << address;
                    ++checked;
                }
            }
        }
        EXPECT_GT(checked, 0U);
    }
    void expect_retry_after_bound(rtu::Duration allowance);
    // Four registers of the ATV21 at address 1, each set to its own value (and its Modbus
    // time-out, F803, off): what a read of each must return.
    std::map<std::uint16_t, std::uint16_t> known_pump_values() {
        EXPECT_TRUE(drives.drive(1)->poke("F803", 0));
        const std::map<std::string, std::uint16_t> by_name{{"FE35", 101}, {"FE36", 202}, {"FA50", 33}, {"FA51", 404}};
        std::map<std::uint16_t, std::uint16_t> values;
        for (const auto& [name, value] : by_name) {
            EXPECT_TRUE(drives.drive(1)->poke(name, value));
            values[static_cast<std::uint16_t>(std::stoul(name, nullptr, 16))] = value;
        }
        return values;
    }
    void expect_silences_kept() const {
        for (const auto& t : line->transmissions()) {
            ASSERT_GE(t.start - t.prior_activity, timing.t3_5) << "a request started too early";
        }
    }
    // Holds back reply `which` from byte `from` on: handed over `after` past the reply's last
    // character on the wire (byte i of a paced reply is on the wire i characters after byte 0).
    void hold(std::size_t which, std::size_t from, rtu::Duration after) {
        line->set_delivery([=, this](std::size_t reply, std::size_t index, rtu::Instant at) {
            if (reply == which && index == 0) {
                held_reply_first_ = at;
            }
            if (reply != which || index < from) {
                return at;
            }
            const auto to_last = static_cast<std::int64_t>(kFanReply - 1 - index);
            return at + timing.character * to_last + after;
        });
    }
};

TEST_F(WireRules, AReplyHeldBackLongerThanT35CompletesAndIsAccepted) {
    add_fan();
    start();
    // Bytes 5-24 of the first reply come in one read, t3.5 after the last of them was on the
    // wire: byte 5 is held back 19 characters + t3.5, far longer than t3.5.
    hold(0, 5, timing.t3_5);
    line->run_for(200ms);
    const auto& c = engine->status().counters;
    EXPECT_EQ(c.held_replies, 1U);
    EXPECT_EQ(c.retries, 0U);
    EXPECT_EQ(c.crc_errors + c.gap_errors, 0U);
    EXPECT_EQ(c.foreign, 0U);
    ASSERT_FALSE(snapshots.empty());
    expect_fan_values_right();
    expect_silences_kept();
}

// On a busy machine the tty worker can hold the rest back for longer than t3.5: up to the
// delivery allowance (50 ms by default) past the bound the frame stays open, and nothing is sent.
TEST_F(WireRules, AReplyHeldBackWithinTheDeliveryAllowanceIsAccepted) {
    add_fan();
    ASSERT_EQ(config.delivery_allowance, rtu::Duration(50ms));
    start();
    hold(0, 5, timing.t3_5 + 45ms);
    line->run_for(300ms);
    const auto& c = engine->status().counters;
    EXPECT_EQ(c.held_replies, 1U);
    EXPECT_EQ(c.retries, 0U);
    EXPECT_EQ(c.crc_errors + c.gap_errors + c.noise, 0U);
    ASSERT_GE(line->transmissions().size(), 2U);
    // The second request waited for the held rest, and then for t3.5 after it.
    const auto rest = held_reply_first_ + timing.character * 24 + timing.t3_5 + 45ms;
    EXPECT_GE(line->transmissions()[1].start, rest + timing.t3_5);
    expect_fan_values_right();
    expect_silences_kept();
}

TEST_F(WireRules, ARetryAfterABrokenReplyNeverStartsBeforeItsWireBound) {
    config.delivery_allowance = rtu::Duration{0};
    expect_retry_after_bound(config.delivery_allowance);
}

TEST_F(WireRules, ARetryAfterABrokenReplyWaitsOutTheDeliveryAllowance) {
    expect_retry_after_bound(config.delivery_allowance);
}

void WireRules::expect_retry_after_bound(rtu::Duration allowance) {
    add_fan();
    start();
    // The rest of the first reply comes three t3.5 after its end and the allowance: past
    // them, so the master takes the reply as broken and retries, but not before the reply can
    // have ended.
    hold(0, 5, timing.t3_5 * 3 + allowance);
    line->run_for(300ms);
    ASSERT_GE(line->transmissions().size(), 2U);
    const auto& first = line->transmissions()[0];
    const auto& retry = line->transmissions()[1];
    EXPECT_EQ(retry.adu.bytes().size(), first.adu.bytes().size());
    // The reply's last character cannot end before 24 characters after its first; the line
    // is free t3.5 after that, and the master waits the allowance out for the rest.
    ASSERT_GT(held_reply_first_, first.start);
    EXPECT_GE(retry.start, held_reply_first_ + timing.character * 24 + timing.t3_5 + allowance);
    const auto& c = engine->status().counters;
    EXPECT_EQ(c.retries, 1U);
    EXPECT_GE(c.crc_errors + c.gap_errors + c.noise, 1U);
    EXPECT_EQ(c.held_replies, 0U);
    expect_fan_values_right();
    expect_silences_kept();
}

TEST_F(WireRules, BytesWaitingInTheInputQueueDelayTheWrite) {
    add_fan(1ms);
    start();
    const rtu::Instant t = kStart + 10ms;
    engine->on_time(t);
    ASSERT_TRUE(engine->line_free(t));
    EXPECT_FALSE(engine->transmission(t, 3).has_value()) << "3 bytes received, not yet read";
    EXPECT_TRUE(engine->transmission(t, 0).has_value());
}

// The response time-out runs until the reply begins: a 125-register reply (255 bytes, 133 ms
// at 19200 bit/s) outlasts the default 100 ms and still succeeds.
TEST_F(WireRules, ALongReplyGetsItsOwnWireTime) {
    config.response_timeout = master::BusPlan{}.response_timeout;
    // A generic slave with 125 registers, each holding its own address + 1000.
    auto meter = std::make_shared<Profile>(*load("generic"));
    for (std::uint16_t a = 0; a < 125; ++a) {
        RegisterInfo r;
        r.name = "R" + std::to_string(a);
        r.address = a;
        r.default_value = 1000 + a;
        meter->registers.push_back(r);
    }
    config.drives.push_back(drive("meter", 5, meter));
    drives.add(sim::make_drive(5, meter));
    start();
    ASSERT_TRUE(engine->submit({1, 77, {5, rtu::ReadHoldingRegisters{0, 125}}, false}).has_value());
    ASSERT_TRUE(line->run_until_true([&] { return !results.empty(); }, 10s));
    const auto& [id, result] = results.front();
    EXPECT_EQ(id, 77U);
    ASSERT_EQ(result.outcome, master::Outcome::Ok) << master::to_string(result.outcome);
    EXPECT_EQ(result.attempts, 1U);
    const auto& values = std::get<rtu::ReadHoldingRegistersResponse>(*result.response).values;
    ASSERT_EQ(values.size(), 125U);
    EXPECT_EQ(values[0], 1000);
    EXPECT_EQ(values[124], 1124);
    EXPECT_GT(rtu::wire_time(timing, 255), config.response_timeout);
    EXPECT_EQ(engine->status().counters.timeouts, 0U);
}

// Replies late by a share of the response time-out, on an Altivar 21 read one register at a
// time (every read has the same shape: address, function, length and CRC cannot tell two
// replies apart). Every value a client gets is the register's own, and a drive that answers
// after the time-out is reported as late, never as silent.
class LateReplies : public WireRules, public ::testing::WithParamInterface<double> {};

TEST_P(LateReplies, NeverGiveAWrongValue) {
    const double factor = GetParam();
    config.response_timeout = 100ms;
    auto d = drive("pump", 1, atv21);
    config.drives.push_back(d);
    drives.add(sim::make_drive(1, atv21));
    const std::map<std::uint16_t, std::uint16_t> values = known_pump_values();
    const auto late = std::chrono::duration_cast<rtu::Duration>(config.response_timeout * factor);
    ASSERT_TRUE(drives.faults().apply(1, "late=" + std::to_string(late.count() / 1000) + "us").has_value());
    start();

    constexpr std::size_t kReads = 10'000;
    constexpr std::size_t kBatch = 32;
    std::vector<std::uint16_t> asked;
    std::size_t ok = 0;
    std::size_t wrong = 0;
    std::map<master::Outcome, std::size_t> outcomes;
    while (asked.size() < kReads) {
        const std::size_t before = results.size();
        for (std::size_t i = 0; i < kBatch && asked.size() < kReads; ++i) {
            const std::uint16_t reg = std::next(values.begin(), static_cast<std::ptrdiff_t>(asked.size() % 4))->first;
            master::ClientRequest r{1, asked.size(), {1, rtu::ReadHoldingRegisters{reg, 1}}, false};
            ASSERT_TRUE(engine->submit(r).has_value());
            asked.push_back(reg);
        }
        ASSERT_TRUE(line->run_until_true([&] { return results.size() == asked.size(); }, 3600s))
            << "answers " << results.size() << " of " << asked.size();
        for (std::size_t i = before; i < results.size(); ++i) {
            const auto& [id, result] = results[i];
            ++outcomes[result.outcome];
            if (result.outcome != master::Outcome::Ok) {
                continue;
            }
            const auto& reply = std::get<rtu::ReadHoldingRegistersResponse>(*result.response);
            ++ok;
            if (reply.values.words()[0] != values.at(asked.at(id))) {
                ++wrong;
            }
        }
    }
    EXPECT_EQ(wrong, 0U) << "of " << ok << " values";
    if (factor < 1.0) {
        EXPECT_EQ(ok, kReads);
        EXPECT_EQ(engine->status().counters.late_replies, 0U);
    } else {
        // Reported as late: never "did not answer".
        EXPECT_EQ(outcomes[master::Outcome::Timeout], 0U);
        EXPECT_GT(engine->status().counters.late_replies, 0U);
        EXPECT_GT(engine->scheduler().snapshot(0).counters.late, 0U);
        EXPECT_EQ(ok + outcomes[master::Outcome::Late], kReads);
    }
    expect_silences_kept();
}

// A drive seen late once has its lateness remembered; when it then answers later still, past
// the time-out and the guard, a retry takes the first attempt's late reply (the same request:
// a right answer), and the retry's own reply is still on its way when the transaction ends. It
// must not land in the next request's wait (found by the soak: FE36 read as FC90's value).
TEST_F(WireRules, ALatenessGrowingPastTheGuardIsNeverTakenForTheNextReply) {
    config.response_timeout = 100ms;
    config.drives.push_back(drive("pump", 1, atv21));
    drives.add(sim::make_drive(1, atv21));
    const std::map<std::uint16_t, std::uint16_t> values = known_pump_values();
    start();
    std::size_t asked = 0;
    std::size_t wrong = 0;
    std::size_t ok = 0;
    const auto reads = [&](std::size_t n) {
        for (std::size_t i = 0; i < n; ++i, ++asked) {
            const std::uint16_t reg = std::next(values.begin(), static_cast<std::ptrdiff_t>(asked % 4))->first;
            results.clear();
            ASSERT_TRUE(engine->submit({1, asked, {1, rtu::ReadHoldingRegisters{reg, 1}}, false}).has_value());
            ASSERT_TRUE(line->run_until_true([&] { return !results.empty(); }, 60s));
            if (results.front().second.outcome == master::Outcome::Ok) {
                ++ok;
                const auto& reply = std::get<rtu::ReadHoldingRegistersResponse>(*results.front().second.response);
                wrong += reply.values.words()[0] != values.at(reg) ? 1U : 0U;
            }
        }
    };
    ASSERT_TRUE(drives.faults().apply(1, "late=110ms").has_value());
    reads(100);
    ASSERT_GT(engine->status().counters.late_replies, 0U) << "the drive was seen late";
    ASSERT_TRUE(drives.faults().apply(1, "late=231ms").has_value());
    reads(1000);
    EXPECT_EQ(wrong, 0U) << "of " << ok << " values";
    EXPECT_GT(ok, 0U);
    expect_silences_kept();
}

// A drive that stalls answers its requests in order but later than any bound the master knows
// (past the response time-out and the guard, from a drive never seen late): the replies to a
// read it gave up on come in the next reads' waits, with the same shape. They are never taken
// for those reads' values: the master sends a sync probe (FC43, whose reply cannot be confused
// with an FC03 one) ahead of the next read, discards what can be an earlier read's reply, and
// sends the read once the probe is answered.
TEST_F(WireRules, AStalledDriveNeverGivesTheNextReadsTheValuesOfTheReadsBefore) {
    config.drives.push_back(drive("pump", 1, atv21));
    drives.add(sim::make_drive(1, atv21));
    const std::map<std::uint16_t, std::uint16_t> values = known_pump_values();
    start();
    std::size_t asked = 0;
    std::vector<master::Result> got;
    const auto read = [&] {
        const std::uint16_t reg = std::next(values.begin(), static_cast<std::ptrdiff_t>(asked % 4))->first;
        results.clear();
        ASSERT_TRUE(engine->submit({1, asked, {1, rtu::ReadHoldingRegisters{reg, 1}}, false}).has_value());
        ASSERT_TRUE(line->run_until_true([&] { return !results.empty(); }, 60s));
        const master::Result& r = results.front().second;
        if (r.outcome == master::Outcome::Ok) {
            EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(*r.response).values.words()[0], values.at(reg))
                << "read " << asked << " of register " << reg;
        }
        got.push_back(r);
        ++asked;
    };
    for (int i = 0; i < 4; ++i) {
        read();
    }
    EXPECT_EQ(engine->status().counters.sync_probes, 0U) << "in step: no probe";
    // The stall: every attempt of one read answered 420 ms late, in order: past its time-out
    // and guard (50 + 50 ms) and past the next read's first, into its second attempt's wait.
    ASSERT_TRUE(drives.faults().apply(1, "late=420ms").has_value());
    read();
    EXPECT_EQ(got.back().outcome, master::Outcome::Timeout);
    ASSERT_TRUE(drives.faults().apply(1, "late=0ms").has_value());
    for (int i = 0; i < 12; ++i) {
        read();
    }
    EXPECT_GT(engine->status().counters.sync_probes, 0U);
    EXPECT_GT(engine->status().counters.late_replies, 0U) << "the stalled replies came, and were discarded";
    // In step again: the last reads are answered at once.
    for (std::size_t i = got.size() - 4; i < got.size(); ++i) {
        EXPECT_EQ(got[i].outcome, master::Outcome::Ok) << "read " << i;
        EXPECT_EQ(got[i].attempts, 1U) << "read " << i;
    }
    expect_silences_kept();
}

// Without retries, a reply 2.5 x the time-out late lands in the next request's wait every
// time: the ledger knows it can be the earlier request's, so it is counted late, never taken.
TEST_F(WireRules, WithoutRetriesALateReplyIsNeverTakenForTheNextRequest) {
    config.response_timeout = 100ms;
    config.retries = 0;
    config.drives.push_back(drive("pump", 1, atv21));
    drives.add(sim::make_drive(1, atv21));
    const std::map<std::uint16_t, std::uint16_t> values = known_pump_values();
    ASSERT_TRUE(drives.faults().apply(1, "late=250ms").has_value());
    start();
    std::size_t ok = 0;
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < 2000; ++i) {
        const std::uint16_t reg = std::next(values.begin(), static_cast<std::ptrdiff_t>(i % 4))->first;
        results.clear();
        ASSERT_TRUE(engine->submit({1, i, {1, rtu::ReadHoldingRegisters{reg, 1}}, false}).has_value());
        ASSERT_TRUE(line->run_until_true([&] { return !results.empty(); }, 60s));
        const master::Result& r = results.front().second;
        if (r.outcome == master::Outcome::Ok) {
            ++ok;
            wrong +=
                std::get<rtu::ReadHoldingRegistersResponse>(*r.response).values.words()[0] != values.at(reg) ? 1U : 0U;
        }
    }
    EXPECT_EQ(wrong, 0U) << "of " << ok << " values";
    EXPECT_GT(engine->status().counters.late_replies, 0U);
    expect_silences_kept();
}

// A request the drive never got (noise on the line) leaves an attempt owed that will never be
// answered: one sync probe settles it, and the next read costs no time-out.
TEST_F(WireRules, ARequestTheDriveNeverGotCostsOneSyncProbe) {
    config.drives.push_back(drive("pump", 1, atv21));
    drives.add(sim::make_drive(1, atv21));
    const std::map<std::uint16_t, std::uint16_t> values = known_pump_values();
    start();
    const auto read = [&](std::uint16_t reg) {
        results.clear();
        EXPECT_TRUE(engine->submit({1, reg, {1, rtu::ReadHoldingRegisters{reg, 1}}, false}).has_value());
        EXPECT_TRUE(line->run_until_true([&] { return !results.empty(); }, 60s));
        return results.empty() ? master::Result{} : results.front().second;
    };
    ASSERT_TRUE(drives.faults().apply(1, "drop=1").has_value());
    EXPECT_EQ(read(0xFE35).outcome, master::Outcome::Timeout);
    ASSERT_TRUE(drives.faults().apply(1, "drop=0").has_value());
    const auto before = engine->status().counters;
    const master::Result next = read(0xFE36);
    ASSERT_EQ(next.outcome, master::Outcome::Ok);
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(*next.response).values.words()[0], values.at(0xFE36));
    EXPECT_EQ(next.attempts, 1U);
    const auto after = engine->status().counters;
    EXPECT_EQ(after.sync_probes - before.sync_probes, 1U);
    EXPECT_EQ(after.transmissions - before.transmissions, 2U) << "the probe and the read";
    EXPECT_EQ(after.timeouts, before.timeouts);
    // Settled: the read after it needs no probe.
    EXPECT_EQ(read(0xFA50).attempts, 1U);
    EXPECT_EQ(engine->status().counters.sync_probes, after.sync_probes);
}

// A drive whose every probe shape is owed: reads of one, two and three registers it never
// answered, then a read of three whose reply comes past the time-out and the guard. The next
// read of three could take that reply, and no probe of a shape nothing owes is left. The probe
// goes out anyway (a read of one register): its reply is matched to the oldest owed read it can
// answer, so it proves the drive in step only when nothing older can be answered by it, and the
// late reply is discarded, never taken for the next read's (the soak found this with seed
// 3817377698: a read of W451-W453 took W450-W452's values).
TEST_F(WireRules, ADriveWithEveryProbeShapeOwedNeverGivesAReadTheValuesOfTheReadBefore) {
    config.response_timeout = 100ms;
    config.retries = 0;
    add_fan();
    config.drives.back().polls.clear();
    start();
    std::size_t wrong = 0;
    std::size_t ok = 0;
    const auto read = [&](std::uint16_t start_at, std::uint16_t quantity) {
        results.clear();
        EXPECT_TRUE(
            engine->submit({1, start_at, {2, rtu::ReadHoldingRegisters{start_at, quantity}}, false}).has_value());
        EXPECT_TRUE(line->run_until_true([&] { return !results.empty(); }, 60s));
        const master::Result r = results.empty() ? master::Result{} : results.front().second;
        if (r.outcome == master::Outcome::Ok) {
            ++ok;
            const auto words = std::get<rtu::ReadHoldingRegistersResponse>(*r.response).values.words();
            for (std::size_t i = 0; i < words.size(); ++i) {
                const auto held = static_cast<std::uint16_t>(4500U + (start_at - 450U) + i);  // the fan's W4xx
                if (words[i] != held) {
                    ++wrong;
                    ADD_FAILURE() << "a read of " << quantity << " from W" << start_at << " gave " << words[i]
                                  << " for W" << start_at + i;
                }
            }
        }
        return r;
    };
    ASSERT_TRUE(drives.faults().apply(2, "drop=1").has_value());
    EXPECT_EQ(read(450, 1).outcome, master::Outcome::Timeout);
    EXPECT_EQ(read(450, 2).outcome, master::Outcome::Timeout);
    ASSERT_TRUE(drives.faults().apply(2, "drop=0").has_value());
    ASSERT_TRUE(drives.faults().apply(2, "late=250ms").has_value());
    EXPECT_EQ(read(450, 3).outcome, master::Outcome::Timeout) << "its reply comes after the time-out and the guard";
    const auto before = engine->status().counters;
    read(451, 3);
    EXPECT_GT(engine->status().counters.sync_probes, before.sync_probes) << "a probe went ahead of the read";
    EXPECT_GT(engine->status().counters.late_replies, before.late_replies) << "the late reply came and was discarded";
    ASSERT_TRUE(drives.faults().apply(2, "late=0ms").has_value());
    for (int i = 0; i < 8; ++i) {
        read(static_cast<std::uint16_t>(450 + i % 3), static_cast<std::uint16_t>(1 + i % 3));
    }
    EXPECT_EQ(wrong, 0U);
    EXPECT_GT(ok, 0U);
    // In step again: the last read is answered at once.
    EXPECT_EQ(read(452, 3).attempts, 1U);
    expect_silences_kept();
}

// A slave with no sync probe to be had (a profile with no register and no FC43) is guarded by
// waiting alone: after a request it never got, the next ones cost no time-out (held to the
// owed attempt, each reply would be taken for an older one's, and each read would pay one).
TEST_F(WireRules, ASlaveWithNoProbePaysNoTimeOutsForARequestItNeverGot) {
    auto meter = std::make_shared<Profile>(*load("generic"));
    ASSERT_TRUE(meter->registers.empty());
    config.drives.push_back(drive("meter", 5, meter));
    drives.add(sim::make_drive(5, meter));
    start();
    const auto read = [&] {
        results.clear();
        EXPECT_TRUE(engine->submit({1, 1, {5, rtu::ReadHoldingRegisters{0, 1}}, false}).has_value());
        EXPECT_TRUE(line->run_until_true([&] { return !results.empty(); }, 60s));
        return results.empty() ? master::Result{} : results.front().second;
    };
    ASSERT_TRUE(drives.faults().apply(5, "drop=1").has_value());
    EXPECT_EQ(read().outcome, master::Outcome::Timeout);
    ASSERT_TRUE(drives.faults().apply(5, "drop=0").has_value());
    for (int i = 0; i < 4; ++i) {
        const master::Result r = read();  // no register: answered with an exception
        EXPECT_EQ(r.outcome, master::Outcome::Exception) << "read " << i;
        EXPECT_EQ(r.attempts, 1U) << "read " << i;
    }
    EXPECT_EQ(engine->status().counters.sync_probes, 0U);
}

INSTANTIATE_TEST_SUITE_P(OfTheTimeout, LateReplies, ::testing::Values(0.5, 0.9, 1.1, 1.5, 2.5),
                         [](const auto& p) { return "x" + std::to_string(static_cast<int>(p.param * 10)); });

}  // namespace
}  // namespace drivebus::test
