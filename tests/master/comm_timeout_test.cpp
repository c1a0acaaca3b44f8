// SPDX-License-Identifier: Apache-2.0
// The drive's own Modbus time-out (ATV21 F803, F603): the check's steps fed by hand (read, write
// only when it differs, read back, refusals), the gap it is judged against, and the check on a
// virtual line against the simulated Altivar 21: read when the drive comes online, the drive's
// F803 written when configured, the note in the drive's snapshot.
#include "master/comm_timeout.hpp"

#include <gtest/gtest.h>

#include "atv21.hpp"
#include "fixtures.hpp"
#include "master/bus_engine.hpp"
#include "sim_fixture.hpp"
#include "virtual_line.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using master::CommTimeoutCheck;
using master::CommTimeoutNote;
using State = CommTimeoutNote::State;
using Verdict = CommTimeoutNote::Verdict;

master::Result words(std::uint16_t value) {
    master::Result r;
    r.outcome = master::Outcome::Ok;
    rtu::ReadHoldingRegistersResponse reply;
    reply.values.push_back(value);
    r.response = reply;
    return r;
}
master::Result written(std::uint16_t reg, std::uint16_t value) {
    master::Result r;
    r.outcome = master::Outcome::Ok;
    r.response = rtu::WriteSingleRegisterResponse{reg, value};
    return r;
}
master::Result refused(rtu::FunctionCode function, rtu::ExceptionCode code) {
    master::Result r;
    r.outcome = master::Outcome::Exception;
    r.response = rtu::ExceptionResponse{static_cast<std::uint8_t>(function), code};
    return r;
}

// The next request reads `reg`, one word.
void expect_read(const CommTimeoutCheck& c, std::uint16_t reg) {
    const auto request = c.next();
    ASSERT_TRUE(request.has_value());
    const auto* r = std::get_if<rtu::ReadHoldingRegisters>(&request->pdu);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->start, reg);
    EXPECT_EQ(r->quantity, 1);
}

class CommTimeoutCheckTest : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");
    CommTimeoutCheck check(std::optional<std::uint16_t> wanted = std::nullopt,
                           std::optional<rtu::Duration> gap = 400ms) const {
        return CommTimeoutCheck(1, *atv21, wanted, gap);
    }
};

TEST_F(CommTimeoutCheckTest, ReadsTheTimeOutThenTheFaultBehaviour) {
    auto c = check();
    expect_read(c, 0x0803);
    EXPECT_FALSE(c.take(words(3)));
    expect_read(c, 0x0603);
    EXPECT_TRUE(c.take(words(1)));
    EXPECT_FALSE(c.next().has_value());
    const auto& n = c.note();
    EXPECT_EQ(n.state, State::Read);
    EXPECT_EQ(n.raw, 3);
    EXPECT_EQ(n.timeout_ms, 3000U);
    EXPECT_EQ(n.verdict, Verdict::Fine);
    EXPECT_TRUE(n.action_read);
    EXPECT_EQ(n.action, 1);
    // Coming online again: read again, from nothing.
    c.restart();
    EXPECT_EQ(c.note().state, State::Unknown);
    expect_read(c, 0x0803);
}

TEST_F(CommTimeoutCheckTest, ZeroIsOffAndShortIsMayFire) {
    auto off = check();
    off.take(words(0));
    off.take(words(0));
    EXPECT_EQ(off.note().verdict, Verdict::Off);
    EXPECT_EQ(off.note().timeout_ms, 0U);
    // 1 s against a gap of 1.3 s.
    auto short_one = check(std::nullopt, 1300ms);
    short_one.take(words(1));
    short_one.take(words(0));
    EXPECT_EQ(short_one.note().verdict, Verdict::MayFire);
    // Nothing bounds the gap: any time-out may fire.
    auto unbounded = check(std::nullopt, std::nullopt);
    unbounded.take(words(100));
    unbounded.take(words(0));
    EXPECT_EQ(unbounded.note().verdict, Verdict::MayFire);
}

TEST_F(CommTimeoutCheckTest, AConfiguredValueIsWrittenOnlyWhenItDiffersAndReadBack) {
    auto same = check(3);
    same.take(words(3));
    expect_read(same, 0x0603);  // no write: the drive holds it already
    same.take(words(0));
    EXPECT_EQ(same.note().state, State::Read);

    auto c = check(2);
    c.take(words(3));
    const auto request = c.next();
    ASSERT_TRUE(request.has_value());
    const auto* w = std::get_if<rtu::WriteSingleRegister>(&request->pdu);
    ASSERT_NE(w, nullptr);
    EXPECT_EQ(w->address, 0x0803);
    EXPECT_EQ(w->value, 2);
    EXPECT_FALSE(c.take(written(0x0803, 2)));
    expect_read(c, 0x0803);  // read back
    c.take(words(2));
    expect_read(c, 0x0603);
    EXPECT_TRUE(c.take(words(1)));
    EXPECT_EQ(c.note().state, State::Written);
    EXPECT_EQ(c.note().raw, 2);
    EXPECT_EQ(c.note().wanted, 2);
    EXPECT_EQ(c.note().verdict, Verdict::Fine);
}

TEST_F(CommTimeoutCheckTest, ARefusalOrAnotherReadBackIsNoted) {
    auto write_refused = check(2);
    write_refused.take(words(0));
    write_refused.take(refused(rtu::FunctionCode::WriteSingleRegister, rtu::ExceptionCode::ServerDeviceFailure));
    expect_read(write_refused, 0x0603);  // the fault behaviour is still read
    write_refused.take(words(0));
    EXPECT_EQ(write_refused.note().state, State::WriteRefused);
    EXPECT_EQ(write_refused.note().exception, 4);
    EXPECT_EQ(write_refused.note().raw, 0);
    EXPECT_EQ(write_refused.note().verdict, Verdict::Off);  // what it still holds

    auto other = check(2);
    other.take(words(3));
    other.take(written(0x0803, 2));
    other.take(words(3));
    other.take(words(0));
    EXPECT_EQ(other.note().state, State::ReadBack);
    EXPECT_EQ(other.note().raw, 3);
    EXPECT_EQ(other.note().verdict, Verdict::Fine);

    auto read_refused = check();
    read_refused.take(refused(rtu::FunctionCode::ReadHoldingRegisters, rtu::ExceptionCode::IllegalDataAddress));
    read_refused.take(words(0));
    EXPECT_EQ(read_refused.note().state, State::ReadRefused);
    EXPECT_EQ(read_refused.note().exception, 2);
    EXPECT_EQ(read_refused.note().verdict, Verdict::None);
}

TEST_F(CommTimeoutCheckTest, AProfileWithoutATimeOutHasNothingToDo) {
    const auto atv58 = load("atv58");
    const CommTimeoutCheck c(2, *atv58, std::nullopt, 1s);
    EXPECT_TRUE(c.empty());
    EXPECT_FALSE(c.next().has_value());
}

TEST(CommTimeoutGap, TheShorterOfKeepAliveAndFastestPollPlusOneExchange) {
    const auto atv21 = load("atv21");
    auto b = bus();  // 50 ms response time-out, 2 retries: 150 ms for an exchange
    auto d = drive("pump", 1, atv21);
    EXPECT_FALSE(master::longest_request_gap(b, d).has_value());
    d.keep_alive = 1s;
    EXPECT_EQ(master::longest_request_gap(b, d), 1150ms);
    d.polls.push_back(poll(*atv21, {"FD00"}, 5s));
    EXPECT_EQ(master::longest_request_gap(b, d), 1150ms);
    d.polls.push_back(poll(*atv21, {"FD01"}, 200ms));
    EXPECT_EQ(master::longest_request_gap(b, d), 350ms);
    d.keep_alive.reset();
    EXPECT_EQ(master::longest_request_gap(b, d), 350ms);
}

TEST(CommTimeoutGap, ConfiguredValueInRawCounts) {
    const auto atv21 = load("atv21");
    auto d = drive("pump", 1, atv21);
    EXPECT_FALSE(master::comm_timeout_raw(d).has_value());
    d.comm_timeout = 2s;
    EXPECT_EQ(master::comm_timeout_raw(d), 2);
    d.comm_timeout = 1500ms;  // not a whole number of seconds
    EXPECT_FALSE(master::comm_timeout_raw(d).has_value());
    d.comm_timeout = 101s;  // above F803's 100
    EXPECT_FALSE(master::comm_timeout_raw(d).has_value());
}

TEST(CommTimeoutWarnings, CheckConfigJudgesTheConfiguredValueOrElseTheFactoryOne) {
    const auto atv21 = load("atv21");
    auto b = bus();
    auto d = drive("pump", 1, atv21);
    d.polls.push_back(poll(*atv21, {"FD00"}, 100ms));
    b.drives.push_back(d);
    EXPECT_TRUE(master::comm_timeout_warnings(b).empty());  // 3 s factory against 250 ms
    b.drives[0].polls[0].period = 5s;
    auto lines = master::comm_timeout_warnings(b);
    ASSERT_EQ(lines.size(), 1U);
    EXPECT_NE(
        lines[0].find("bus 'test' drive 'pump': F803 at its factory setting (3 s; what the drive holds is read when it "
                      "comes online) is not longer than"),
        std::string::npos)
        << lines[0];
    EXPECT_NE(lines[0].find("up to 5.15 s"), std::string::npos) << lines[0];
    b.drives[0].comm_timeout = 10s;
    EXPECT_TRUE(master::comm_timeout_warnings(b).empty());
    b.drives[0].comm_timeout = 4s;
    lines = master::comm_timeout_warnings(b);
    ASSERT_EQ(lines.size(), 1U);
    EXPECT_NE(lines[0].find("its comm_timeout of 4 s is not longer than"), std::string::npos) << lines[0];
    // No [safety] in the profile: nothing to say.
    b.drives[0].profile = load("atv58");
    b.drives[0].comm_timeout.reset();
    EXPECT_TRUE(master::comm_timeout_warnings(b).empty());
}

// ---------------------------------------------------------------------------------------------
// On the virtual line

const rtu::Instant kStart{std::chrono::seconds(100)};

class CommTimeoutLineTest : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");
    master::BusPlan config = bus();
    rtu::CharacterTiming timing = rtu::character_timing(config.format).value();
    std::vector<master::DriveSnapshot> snapshots;
    std::unique_ptr<master::BusEngine> engine;
    sim::Bus drives{{timing, 1ms, true, 3}};
    std::unique_ptr<VirtualLine> line;

    master::DrivePlan& add_pump(std::shared_ptr<const Profile> master_profile = nullptr) {
        auto d = drive("pump", 1, master_profile ? master_profile : atv21);
        d.polls.push_back(poll(*atv21, {"FD00", "FD01"}, 100ms));
        d.keep_alive = 1s;
        config.drives.push_back(d);
        drives.add(sim::make_drive(1, atv21));
        return config.drives.back();
    }
    void start() {
        master::EngineCallbacks callbacks;
        callbacks.snapshot = [this](const master::DriveSnapshot& s) { snapshots.push_back(s); };
        engine = std::make_unique<master::BusEngine>(config, timing, callbacks, kStart);
        engine->line_up(kStart);
        line = std::make_unique<VirtualLine>(*engine, drives, timing, kStart);
    }
    // Runs until the pump's snapshot carries a finished check.
    const CommTimeoutNote& checked(rtu::Duration limit = 2s) {
        EXPECT_TRUE(line->run_until_true(
            [&] { return !snapshots.empty() && snapshots.back().comm_timeout.state != State::Unknown; }, limit));
        return snapshots.back().comm_timeout;
    }
    [[nodiscard]] std::size_t writes_to(std::uint16_t reg) const {
        std::size_t n = 0;
        for (const auto& t : line->transmissions()) {
            n += t.adu[1] == 0x06 && ((t.adu[2] << 8) | t.adu[3]) == reg ? 1U : 0U;
        }
        return n;
    }
};

TEST_F(CommTimeoutLineTest, APumpWithF803OffIsSeenOff) {
    add_pump();
    ASSERT_TRUE(drives.drive(1)->poke("F803", 0).has_value());
    ASSERT_TRUE(drives.drive(1)->poke("F603", 2).has_value());
    start();
    const auto note = checked();
    EXPECT_EQ(note.state, State::Read);
    EXPECT_EQ(note.raw, 0);
    EXPECT_EQ(note.verdict, Verdict::Off);
    EXPECT_TRUE(note.action_read);
    EXPECT_EQ(note.action, 2);
    EXPECT_EQ(writes_to(0x0803), 0U);  // never written unless configured
    // The first snapshot that carries it is a poll cycle's, with the values.
    EXPECT_TRUE(snapshots.back().registers.at(0xFD01).valid);
    const auto line_text = master::comm_timeout_line(config, config.drives[0], note);
    ASSERT_TRUE(line_text.has_value());
    EXPECT_TRUE(line_text->warning);
    EXPECT_NE(line_text->text.find("bus test drive pump: Modbus time-out F803 = 0 (off); on a time-out: F603 = 2"),
              std::string::npos)
        << line_text->text;
    EXPECT_NE(line_text->text.find("the drive runs on at its last command"), std::string::npos) << line_text->text;
}

TEST_F(CommTimeoutLineTest, AFactoryPumpPolledOftenIsFine) {
    add_pump();
    start();
    const auto note = checked();
    EXPECT_EQ(note.state, State::Read);
    EXPECT_EQ(note.timeout_ms, 3000U);
    EXPECT_EQ(note.verdict, Verdict::Fine);
    const auto text = master::comm_timeout_line(config, config.drives[0], note);
    ASSERT_TRUE(text.has_value());
    EXPECT_FALSE(text->warning) << text->text;
}

TEST_F(CommTimeoutLineTest, AKeepAliveLongerThanTheTimeOutMayLetItFire) {
    auto& d = add_pump();
    d.polls.clear();
    d.keep_alive = 5s;
    start();
    // Nothing polls it: its first request is the keep-alive after 5 s, then the check, published
    // when it ends.
    const auto note = checked(10s);
    EXPECT_EQ(note.verdict, Verdict::MayFire);
    const auto text = master::comm_timeout_line(config, config.drives[0], note);
    ASSERT_TRUE(text.has_value());
    EXPECT_NE(text->text.find("up to 5.15 s between two requests"), std::string::npos) << text->text;
}

TEST_F(CommTimeoutLineTest, AConfiguredTimeOutIsWrittenOnceAndReadBack) {
    auto& d = add_pump();
    d.comm_timeout = 2s;
    start();
    const auto note = checked();
    EXPECT_EQ(note.state, State::Written);
    EXPECT_EQ(note.raw, 2);
    EXPECT_EQ(drives.drive(1)->peek("F803").value(), 2);
    EXPECT_EQ(writes_to(0x0803), 1U);
    // Back from an absence: read again, and not written, as it holds the value.
    ASSERT_TRUE(drives.faults().apply(1, "drop=1").has_value());
    ASSERT_TRUE(line->run_until_true([&] { return snapshots.back().health == master::Health::Absent; }, 5s));
    drives.faults().clear(std::nullopt);
    snapshots.clear();
    EXPECT_EQ(checked().state, State::Read);
    EXPECT_EQ(writes_to(0x0803), 1U);
}

TEST_F(CommTimeoutLineTest, AWriteTheDriveRefusesIsNotedAndThePumpStillPolled) {
    // The master's profile lets F803 go to 200 s; the drive's stops at 100 and refuses 150.
    auto wide = std::make_shared<Profile>(*atv21);
    for (auto& r : wide->registers) {
        if (r.name == "F803") {
            r.max = 200;
        }
    }
    auto& d = add_pump(wide);
    d.comm_timeout = 150s;
    start();
    const auto note = checked();
    EXPECT_EQ(note.state, State::WriteRefused);
    EXPECT_EQ(note.exception, 3);
    EXPECT_EQ(note.raw, 3);  // what it still holds
    EXPECT_EQ(drives.drive(1)->peek("F803").value(), 3);
    EXPECT_EQ(snapshots.back().health, master::Health::Online);
    EXPECT_TRUE(snapshots.back().registers.at(0xFD00).valid);
    const auto text = master::comm_timeout_line(config, config.drives[0], note);
    ASSERT_TRUE(text.has_value());
    EXPECT_TRUE(text->warning);
    EXPECT_NE(text->text.find("F803 was not written 150 (exception 3); the drive holds F803 = 3 (3 s)"),
              std::string::npos)
        << text->text;
}

TEST_F(CommTimeoutLineTest, ADriveNothingHasReachedIsNotAskedUntilItAnswers) {
    auto& d = add_pump();
    d.polls.clear();
    d.keep_alive.reset();
    start();
    line->run_for(2s);
    EXPECT_TRUE(line->transmissions().empty()) << "nothing polled: only what clients ask";
    // A client's read brings it online: then its time-out is read.
    ASSERT_TRUE(engine->submit({7, 1, {1, rtu::ReadHoldingRegisters{0xFD00, 1}}}).has_value());
    EXPECT_EQ(checked().state, State::Read);
    const auto reads_f803 = std::ranges::count_if(
        line->transmissions(), [](const auto& t) { return t.adu[1] == 0x03 && t.adu[2] == 0x08 && t.adu[3] == 0x03; });
    EXPECT_EQ(reads_f803, 1);
}

}  // namespace
}  // namespace drivebus::test
