// SPDX-License-Identifier: Apache-2.0
// The lease record and what the lease policy makes of it (docs/ipc.md, "Expiry and the
// fallback"): which leases are kept, read back however damaged, and how a stop and a start
// turn them into fallbacks. Pure: no file, no RouDi, time as an argument.
#include <gtest/gtest.h>

#include "config/config.hpp"
#include "ipc/intake_core.hpp"
#include "ipc/lease_policy.hpp"
#include "ipc/lease_record.hpp"
#include "read_bus.hpp"

namespace drivebus::ipc {
namespace {

using namespace std::chrono_literals;

config::BusConfig bus() {
    return test::read_bus(test::pump_and_fan_toml({R"(lease = "500ms")", R"(fallback = "stop")"}));
}

TokenSource counting_tokens() {
    return [n = std::uint64_t{0}]() mutable { return LeaseToken{++n, 0x5A5A5A5A5A5A5A5AULL}; };
}

Origin client(std::string name, std::uint64_t id) {
    Origin o{1, id, std::move(name), shm::RequestKind::Write, 0};
    o.pid = static_cast<std::int32_t>(id);
    return o;
}

const rtu::Request kStop = rtu::WriteSingleRegister{0xFA00, 0xC000};

TEST(LeaseRecord, WritesAndReadsBackWhatItKeeps) {
    const std::vector<RecordedLease> leases = {
        {"pump", 1, config::LeaseFallback::Stop, "pump-control[12]"},
        {"fan", 2, config::LeaseFallback::Hold, "a b\nc"},  // a holder's name is the client's own word
    };
    const auto text = format_lease_record(leases);
    EXPECT_EQ(text, "drivebus-leases 1\nlease pump 1 stop pump-control[12]\nlease fan 2 hold a b?c\n");
    const auto read = parse_lease_record(text);
    EXPECT_TRUE(read.problems.empty());
    ASSERT_EQ(read.leases.size(), 2U);
    EXPECT_EQ(read.leases[0], leases[0]);
    EXPECT_EQ(read.leases[1].holder, "a b?c");
    EXPECT_TRUE(parse_lease_record(format_lease_record({})).leases.empty());
    RecordedLease unconfirmed{"pump", 1, config::LeaseFallback::Stop, "x", true};
    EXPECT_EQ(format_lease_record({unconfirmed}), "drivebus-leases 1\nunconfirmed pump 1 stop x\n");
    EXPECT_EQ(parse_lease_record(format_lease_record({unconfirmed})).leases, std::vector{unconfirmed});
    EXPECT_TRUE(parse_lease_record(format_lease_record({})).problems.empty());
}

// Whatever is damaged, every line that names a drive still counts: its fallback comes from the
// configuration, not from the file.
TEST(LeaseRecord, ADamagedFileIsReadAsFarAsItCanBe) {
    const auto read =
        parse_lease_record("drivebus-leases 7\nlease pump\nnonsense here\nlease fan 300 sideways x\nlease");
    ASSERT_EQ(read.leases.size(), 2U);
    EXPECT_EQ(read.leases[0].drive, "pump");
    EXPECT_FALSE(read.leases[0].address.has_value());
    EXPECT_EQ(read.leases[1].drive, "fan");
    EXPECT_FALSE(read.leases[1].address.has_value()) << "300 is no slave address";
    EXPECT_FALSE(read.leases[1].fallback.has_value());
    const std::vector<std::string> problems = {"line 1 is not \"drivebus-leases 1\"", "line 2 (drive pump) is damaged",
                                               "line 3 is not a lease", "line 4 (drive fan) is damaged",
                                               "line 5 names no drive"};
    EXPECT_EQ(read.problems, problems);
    EXPECT_EQ(parse_lease_record("").problems, std::vector<std::string>{"it is empty"});
    EXPECT_TRUE(parse_lease_record("\x7f\x01\xff garbage").leases.empty());
    // The header's line may itself be a lease (a file cut at its start).
    EXPECT_EQ(parse_lease_record("lease pump 1 stop x\n").leases.size(), 1U);
}

// The record follows who holds what: a grant, a take-over, a release, an expiry and a fallback's
// answer change it; a renewal does not.
TEST(LeaseRecord, ThePolicyKeepsTheHeldLeasesAndTheUnansweredFallbacks) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    EXPECT_TRUE(p.record().empty());
    auto a = client("a", 11);
    a.token = p.command(0, a, false, t0).token;
    const std::vector<RecordedLease> held_by_a = {{"pump", 1, config::LeaseFallback::Stop, "a"}};
    EXPECT_EQ(p.record(), held_by_a);
    (void)p.command(0, a, false, t0 + 100ms);
    (void)p.renew(0, a, t0 + 200ms);
    EXPECT_EQ(p.record(), held_by_a) << "renewals leave it as it was";
    auto other = client("b", 22);
    other.token = p.command(0, other, true, t0 + 300ms).token;
    EXPECT_EQ(p.record().at(0).holder, "b") << "taken over";
    EXPECT_EQ(p.release(0, other).status, shm::Status::Ok);
    EXPECT_TRUE(p.record().empty());
    a.token = p.command(0, a, false, t0 + 1s).token;
    const auto expired = p.expire(t0 + 2s);
    ASSERT_EQ(expired.size(), 1U);
    EXPECT_EQ(p.record(), held_by_a) << "run out, its fallback not yet answered";
    EXPECT_TRUE(p.fallbacks_pending());
    (void)p.fallback_done(0, master::Outcome::Ok, false);
    EXPECT_TRUE(p.record().empty()) << "confirmed: nothing left to apply";
    EXPECT_FALSE(p.fallbacks_pending());
}

// A fallback write that fails is not dropped: it stays in the record, marked unconfirmed, and
// is written again (1 s after the failure, then 2 s, 4 s ... up to 30 s) until the drive
// confirms it.
TEST(LeaseRecord, AFailedFallbackStaysRecordedAndIsWrittenAgainUntilConfirmed) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    auto a = client("a", 11);
    a.token = p.command(0, a, false, t0).token;
    ASSERT_EQ(p.expire(t0 + 1s).size(), 1U);
    const auto failed = p.fallback_done(0, master::Outcome::Timeout, false);
    ASSERT_TRUE(failed.note.has_value());
    EXPECT_EQ(failed.note->level, log::Level::Error);
    EXPECT_NE(failed.note->text.find("it stays in the lease record and is written again"), std::string::npos)
        << failed.note->text;
    EXPECT_FALSE(p.fallbacks_pending()) << "answered: a stopping drivebusd does not wait for the retries";
    const std::vector<RecordedLease> unconfirmed = {{"pump", 1, config::LeaseFallback::Stop, "a", true}};
    EXPECT_EQ(p.record(), unconfirmed);
    EXPECT_EQ(p.status(0).fallback_ok, 0);
    // The first tick after the failure sets the next try.
    const auto t1 = t0 + 1100ms;
    EXPECT_TRUE(p.expire(t1).empty());
    ASSERT_TRUE(p.next_deadline().has_value());
    EXPECT_EQ(*p.next_deadline(), t1 + 1s);
    EXPECT_TRUE(p.expire(t1 + 999ms).empty());
    auto again = p.expire(t1 + 1s);
    ASSERT_EQ(again.size(), 1U);
    ASSERT_TRUE(again[0].write.has_value());
    EXPECT_EQ(again[0].write->pdu, kStop);
    EXPECT_NE(again[0].note.text.find("writing the unconfirmed fallback again (try 2): stop"), std::string::npos)
        << again[0].note.text;
    EXPECT_TRUE(p.fallbacks_pending());
    EXPECT_TRUE(p.expire(t1 + 5s).empty()) << "one write at a time";
    // Refused by the bus this time (the line down): the next wait doubles.
    EXPECT_EQ(p.fallback_done(0, master::Outcome::BusDown, true).note->level, log::Level::Warning);
    const auto t2 = t1 + 2s;
    EXPECT_TRUE(p.expire(t2).empty());
    EXPECT_EQ(*p.next_deadline(), t2 + 2s);
    ASSERT_EQ(p.expire(t2 + 2s).size(), 1U);
    const auto confirmed = p.fallback_done(0, master::Outcome::Ok, false);
    ASSERT_TRUE(confirmed.note.has_value());
    EXPECT_NE(confirmed.note->text.find("the fallback is confirmed, after 2 failed write(s)"), std::string::npos)
        << confirmed.note->text;
    EXPECT_TRUE(p.record().empty());
    EXPECT_EQ(p.status(0).fallback_ok, 1);
    EXPECT_FALSE(p.next_deadline().has_value());
    EXPECT_TRUE(p.expire(t2 + 1min).empty());
}

// The waits double up to 30 s and stay there: a drive off the line costs one time-out a try.
TEST(LeaseRecord, TheRetriesOfAnUnconfirmedFallbackBackOffToThirtySeconds) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    auto now = rtu::Instant{};
    auto a = client("a", 11);
    a.token = p.command(0, a, false, now).token;
    now += 1s;
    ASSERT_EQ(p.expire(now).size(), 1U);
    std::vector<std::int64_t> waits;
    for (int i = 0; i < 8; ++i) {
        (void)p.fallback_done(0, master::Outcome::Timeout, false);
        now += 10ms;
        ASSERT_TRUE(p.expire(now).empty());
        const auto next = p.next_deadline();
        ASSERT_TRUE(next.has_value());
        waits.push_back(std::chrono::duration_cast<std::chrono::seconds>(*next - now).count());
        now = *next;
        ASSERT_EQ(p.expire(now).size(), 1U);
    }
    EXPECT_EQ(waits, (std::vector<std::int64_t>{1, 2, 4, 8, 16, 30, 30, 30}));
}

// A holder that commands the drive after the failed fallback is in control: the retries end
// once its command has reached the wire, and its lease is what the record holds.
TEST(LeaseRecord, ANewHolderEndsTheRetriesOfAnUnconfirmedFallback) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    auto a = client("a", 11);
    a.token = p.command(0, a, false, t0).token;
    ASSERT_EQ(p.expire(t0 + 1s).size(), 1U);
    (void)p.fallback_done(0, master::Outcome::Timeout, false);
    auto c = client("c", 33);
    const auto taken = p.command(0, c, false, t0 + 2s, 7);
    ASSERT_EQ(taken.status, shm::Status::Ok);
    EXPECT_TRUE(p.expire(t0 + 10s).empty()) << "held: no fallback is written under a holder";
    // Its command refused before the wire: the drive is back where it was, retries included.
    (void)p.settle(0, 7, false);
    EXPECT_EQ(p.record().at(0).unconfirmed, true);
    c.token = p.command(0, c, false, t0 + 11s, 8).token;
    const auto sent = p.settle(0, 8, true);
    ASSERT_TRUE(sent.note.has_value());
    EXPECT_NE(sent.note->text.find("the unconfirmed fallback is no longer written again"), std::string::npos);
    const std::vector<RecordedLease> held_by_c = {{"pump", 1, config::LeaseFallback::Stop, "c"}};
    EXPECT_EQ(p.record(), held_by_c);
    EXPECT_EQ(p.release(0, c).status, shm::Status::Ok);
    EXPECT_TRUE(p.record().empty());
    EXPECT_FALSE(p.next_deadline().has_value());
}

// drivebusd stops: every lease held ends now, with its fallback, whatever its deadline.
TEST(LeaseRecord, ASurrenderEndsEveryHeldLeaseWithItsFallback) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    auto a = client("a", 11);
    a.token = p.command(0, a, false, t0).token;
    auto f = client("f", 12);
    f.drive = 1;
    f.token = p.command(1, f, false, t0).token;
    const auto ends = p.surrender(t0 + 10ms);
    ASSERT_EQ(ends.size(), 2U);
    ASSERT_TRUE(ends[0].write.has_value());
    EXPECT_EQ(ends[0].write->pdu, kStop);
    EXPECT_NE(ends[0].note.text.find("drivebusd is stopping: the control lease of a ends; fallback: stop"),
              std::string::npos)
        << ends[0].note.text;
    EXPECT_FALSE(ends[1].write.has_value()) << "the fan holds";
    EXPECT_EQ(p.status(0).state, shm::LeaseState::Expired);
    EXPECT_EQ(p.renew(0, a, t0 + 20ms).status, shm::Status::NotPermitted);
    EXPECT_EQ(p.record().size(), 1U) << "the pump's stop word is on its way";
    (void)p.fallback_done(0, master::Outcome::Ok, false);
    EXPECT_TRUE(p.record().empty());
    EXPECT_TRUE(p.surrender(t0 + 30ms).empty());
}

// drivebusd stops while a fallback is unconfirmed: it is written once more; failed again, the
// record keeps it for the next drivebusd (it was dropped before: an empty record, the drive
// left running).
TEST(LeaseRecord, AStopWritesAnUnconfirmedFallbackOnceMoreAndKeepsItIfItFailsAgain) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    auto a = client("a", 11);
    a.token = p.command(0, a, false, t0).token;
    const auto ends = p.surrender(t0 + 10ms);
    ASSERT_EQ(ends.size(), 1U);
    (void)p.fallback_done(0, master::Outcome::Timeout, false);
    EXPECT_EQ(format_lease_record(p.record()), "drivebus-leases 1\nunconfirmed pump 1 stop a\n");
    const auto more = p.surrender(t0 + 20ms);
    ASSERT_EQ(more.size(), 1U);
    ASSERT_TRUE(more[0].write.has_value());
    EXPECT_NE(more[0].note.text.find("drivebusd is stopping: the fallback for the lease of a is not confirmed; "
                                     "writing it once more: stop"),
              std::string::npos)
        << more[0].note.text;
    (void)p.fallback_done(0, master::Outcome::BusDown, true);
    EXPECT_EQ(format_lease_record(p.record()), "drivebus-leases 1\nunconfirmed pump 1 stop a\n");
    // A reload carries it to the restarted bus's policy.
    const auto carried = p.carry();
    ASSERT_EQ(carried.size(), 1U);
    EXPECT_TRUE(carried[0].unconfirmed);
    LeasePolicy q(b, counting_tokens());
    const auto notes = q.adopt(carried);
    ASSERT_EQ(notes.size(), 1U);
    EXPECT_NE(notes[0].text.find("is not confirmed yet: it is written again after the reload"), std::string::npos);
    EXPECT_EQ(q.record(), p.record());
    EXPECT_TRUE(q.expire(t0 + 1s).empty());
    ASSERT_EQ(q.expire(t0 + 3s).size(), 1U);
}

// drivebusd starts: each drive the record names gets its fallback as configured now, and its
// lease is published expired, naming the holder; a drive no longer configured is a line.
TEST(LeaseRecord, ARecoveryAppliesTheConfiguredFallbackOfEachRecordedDrive) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    ReadLeaseRecord read;
    read.leases = {{"pump", 7, config::LeaseFallback::Hold, "pump-control[99]"},
                   {"gone", 3, config::LeaseFallback::Stop, "x"},
                   {"pump", 1, config::LeaseFallback::Stop, "twice"}};
    read.problems = {"line 9 is not a lease"};
    const auto r = p.recover(read, t0);
    ASSERT_EQ(r.fallbacks.size(), 1U);
    EXPECT_EQ(r.fallbacks[0].drive, 0U);
    ASSERT_TRUE(r.fallbacks[0].write.has_value()) << "stop as configured now, not hold as recorded";
    EXPECT_EQ(r.fallbacks[0].write->address, 1) << "at the configured address";
    EXPECT_EQ(r.fallbacks[0].write->pdu, kStop);
    EXPECT_EQ(r.fallbacks[0].note.level, log::Level::Warning);
    EXPECT_NE(r.fallbacks[0].note.text.find("the lease of pump-control[99] was held when drivebusd last stopped; "
                                            "applying its fallback: stop (recorded at address 7, configured at 1 now)"),
              std::string::npos)
        << r.fallbacks[0].note.text;
    ASSERT_EQ(r.notes.size(), 2U);
    EXPECT_NE(r.notes[0].text.find("lease record: line 9 is not a lease"), std::string::npos) << r.notes[0].text;
    EXPECT_NE(r.notes[1].text.find("drive gone"), std::string::npos) << r.notes[1].text;
    EXPECT_EQ(p.status(0).state, shm::LeaseState::Expired);
    EXPECT_EQ(shm::view(p.status(0).holder), "pump-control[99]");
    EXPECT_EQ(p.status(0).expiries, 1U);
    // Kept until the drive answers, so that a drivebusd killed meanwhile applies it again.
    EXPECT_EQ(p.record().size(), 1U);
    (void)p.fallback_done(0, master::Outcome::Ok, false);
    EXPECT_TRUE(p.record().empty());
    EXPECT_EQ(p.status(0).fallback_ok, 1);
    // Nothing recorded: nothing applied.
    LeasePolicy q(b, counting_tokens());
    EXPECT_TRUE(q.recover({}, t0).fallbacks.empty());
    // An unconfirmed fallback is applied again, and the line says which it was.
    LeasePolicy u(b, counting_tokens());
    ReadLeaseRecord unconfirmed;
    unconfirmed.leases = {{"pump", 1, config::LeaseFallback::Stop, "pump-control[99]", true}};
    const auto again = u.recover(unconfirmed, t0);
    ASSERT_EQ(again.fallbacks.size(), 1U);
    EXPECT_NE(again.fallbacks[0].note.text.find("the fallback for the lease of pump-control[99] was not confirmed "
                                                "when drivebusd last stopped; applying it again: stop"),
              std::string::npos)
        << again.fallbacks[0].note.text;
}

// The record is written ahead: a command that takes a lease goes to the bus only after the
// journal has been asked to make the record (naming its holder) durable; a renewal, a read and
// a refused command write nothing.
TEST(LeaseRecord, TheRecordNamesTheHolderBeforeItsFirstCommandIsSent) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    std::vector<std::string> events;
    IntakeCore intake(
        b, p,
        [&](const master::ClientRequest&) {
            events.emplace_back("submit");
            return true;
        },
        [&] {
            const auto r = p.record();
            events.push_back("record " + (r.empty() ? std::string("empty") : r.at(0).holder));
        });
    shm::Request r{};
    r.size = sizeof r;
    r.kind = shm::RequestKind::Write;
    shm::assign(r.drive, "pump");
    shm::assign(r.client_name, "a");
    r.client = 11;
    r.correlation = 1;
    r.start = 0xFA00;
    r.values[0] = 0xC400;
    r.count = 1;
    RouteId route = 0;
    ASSERT_FALSE(intake.accept(r, route, true, rtu::Instant{}).has_value());
    EXPECT_EQ(events, (std::vector<std::string>{"record a", "submit"}));
    // Another client's command is refused: nothing journaled, nothing sent.
    events.clear();
    auto other = r;
    shm::assign(other.client_name, "b");
    other.client = 22;
    const auto refused = intake.accept(other, route, true, rtu::Instant{});
    ASSERT_TRUE(refused.has_value());
    EXPECT_EQ(refused->status, shm::Status::NotPermitted);
    EXPECT_TRUE(events.empty());
    // A read of the same drive goes to the bus without the journal.
    auto read = r;
    read.kind = shm::RequestKind::Read;
    read.correlation = 2;
    read.start = 0xFD00;
    ASSERT_FALSE(intake.accept(read, route, true, rtu::Instant{}).has_value());
    EXPECT_EQ(events, std::vector<std::string>{"submit"});
}

// A stopping drivebusd's intake answers every request bus down: none takes the lease again.
TEST(LeaseRecord, AClosedIntakeTakesNoLeaseAndSendsNothing) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    std::size_t submitted = 0;
    IntakeCore intake(b, p, [&](const master::ClientRequest&) { return ++submitted, true; });
    intake.close();
    shm::Request r{};
    r.size = sizeof r;
    r.kind = shm::RequestKind::Write;
    shm::assign(r.drive, "pump");
    r.start = 0xFA00;
    r.values[0] = 0xC400;
    r.count = 1;
    RouteId route = 0;
    const auto answer = intake.accept(r, route, true, rtu::Instant{});
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->status, shm::Status::BusDown);
    EXPECT_EQ(submitted, 0U);
    EXPECT_EQ(p.status(0).state, shm::LeaseState::Free);
}

}  // namespace
}  // namespace drivebus::ipc
