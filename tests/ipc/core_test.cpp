// SPDX-License-Identifier: Apache-2.0
// The pure half of drivebusd's iceoryx side: what a request must pass before the wire
// (admission), the control lease, and the payloads built from the master's state.
#include <gtest/gtest.h>

#include "config/config.hpp"
#include "ipc/admission.hpp"
#include "ipc/convert.hpp"
#include "ipc/lease.hpp"
#include "ipc/lease_policy.hpp"
#include "ipc/pending.hpp"
#include "master/block_setup.hpp"
#include "read_bus.hpp"

namespace drivebus::ipc {
namespace {

using namespace std::chrono_literals;
using shm::RejectReason;

// The pump, its lease 500 ms, and the fan.
config::BusConfig bus() {
    return test::read_bus(test::pump_and_fan_toml({R"(lease = "500ms")"}));
}

config::BusConfig bus(std::string_view text) {
    return test::read_bus(text);
}

shm::Request request(shm::RequestKind kind, std::string_view drive, std::uint16_t start,
                     std::initializer_list<std::uint16_t> values = {}, std::uint16_t count = 0) {
    shm::Request r;
    r.size = sizeof r;
    r.kind = kind;
    shm::assign(r.drive, drive);
    r.start = start;
    std::size_t i = 0;
    for (const auto v : values) {
        r.values.at(i++) = v;
    }
    r.count = count != 0 ? count : static_cast<std::uint16_t>(values.size());
    return r;
}

RejectReason reason_of(const config::BusConfig& b, const shm::Request& r) {
    const auto a = admit(b, r);
    return a ? RejectReason::None : a.error().reason;
}

TEST(Admission, AReadBecomesAnFc03ToTheDrivesAddress) {
    const auto b = bus();
    const auto a = admit(b, request(shm::RequestKind::Read, "pump", 0xFD00, {}, 1));
    ASSERT_TRUE(a) << a.error().why;
    EXPECT_EQ(a->drive, 0U);
    EXPECT_EQ(a->request.address, 1);
    EXPECT_EQ(a->request.pdu, rtu::Request(rtu::ReadHoldingRegisters{0xFD00, 1}));
    EXPECT_FALSE(a->touches_control);
}

TEST(Admission, DrivesByAddressWhenNoNameIsGiven) {
    const auto b = bus();
    auto r = request(shm::RequestKind::Read, "", 0x01C2, {}, 3);  // W450..W452
    r.address = 2;
    const auto a = admit(b, r);
    ASSERT_TRUE(a) << a.error().why;
    EXPECT_EQ(a->drive, 1U);
}

TEST(Admission, EveryRejectionKind) {
    const auto b = bus();
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "valve", 0xFD00, {}, 1)), RejectReason::UnknownDrive);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0x1234, {}, 1)), RejectReason::UnknownRegister);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Write, "pump", 0xFD00, {1})), RejectReason::ReadOnly);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Write, "pump", 0x0803, {101})), RejectReason::ValueOutOfRange);
    // The ATV21 reads one register per plain FC03.
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0xFD00, {}, 2)), RejectReason::Quantity);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "fan", 0x01C2, {}, 126)), RejectReason::Quantity);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0xFD00, {}, 0)), RejectReason::Quantity);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Identify, "fan", 0)), RejectReason::Unsupported);
    auto fc16 = request(shm::RequestKind::Write, "pump", 0x0803, {10});
    fc16.function = 16;  // FC16 of one word is fine by the spec, and the ATV21 takes it
    EXPECT_EQ(reason_of(b, fc16), RejectReason::None);
    auto bad = request(shm::RequestKind::Read, "pump", 0xFD00, {}, 1);
    bad.version = 99;
    EXPECT_EQ(reason_of(b, bad), RejectReason::Malformed);
    bad = request(shm::RequestKind::Read, "pump", 0xFD00, {}, 1);
    bad.size = 12;
    EXPECT_EQ(reason_of(b, bad), RejectReason::Malformed);
}

// The pump as drivebusd sets it up: its read block polls FD00 and FD01 (F875 = 2, F876 = 1, the
// other selectors 0), its write block selects the command FA00 and the reference FA01 (F870 = 1,
// F871 = 3).
constexpr std::string_view kBlocks = R"([[bus]]
name = "line1"
device = "/dev/ttyUSB0"
parity = "none"
  [[bus.drive]]
  name = "pump"
  address = 1
  profile = "atv21"
  write_block = ["FA00", "FA01"]
    [[bus.drive.poll]]
    registers = ["FD00", "FD01"]
    indirect = true
    period = "100ms"
  [[bus.drive]]
  name = "tank"
  address = 3
  profile = "atv21"
  write_block = ["FA51", "FA50"]
)";

TEST(Admission, TheIndirectBlocksKeepTheirOwnRules) {
    const auto b = bus(kBlocks);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0x1875, {}, 2)), RejectReason::None);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0x1875, {}, 6)), RejectReason::Quantity);
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0x1876, {}, 2)), RejectReason::UnknownRegister);
}

TEST(Admission, TheSelectorsOfEveryBlockBelongToDrivebusd) {
    const auto b = bus(kBlocks);
    // Writing F875 = 3 would make the read block return FE03 (output current) where drivebusd
    // publishes FD00 (output frequency).
    const auto a = admit(b, request(shm::RequestKind::Write, "pump", 0x0875, {3}));
    ASSERT_FALSE(a);
    EXPECT_EQ(a.error().reason, RejectReason::DaemonOwned);
    EXPECT_EQ(a.error().register_address, 0x0875);
    EXPECT_EQ(a.error().why, "F875 is owned by drivebusd: selector of the read block at 0x1875");
    // Every selector, of both blocks, with FC06 or FC16, a value the profile would take or not.
    for (const std::uint16_t selector :
         std::initializer_list<std::uint16_t>{0x0870, 0x0871, 0x0875, 0x0876, 0x0877, 0x0878, 0x0879}) {
        for (const std::uint16_t value : std::initializer_list<std::uint16_t>{0, 1, 3}) {
            auto w = request(shm::RequestKind::Write, "pump", selector, {value});
            EXPECT_EQ(reason_of(b, w), RejectReason::DaemonOwned) << std::hex << selector;
            w.function = 16;
            EXPECT_EQ(reason_of(b, w), RejectReason::DaemonOwned) << std::hex << selector;
        }
    }
    EXPECT_EQ(admit(b, request(shm::RequestKind::Write, "pump", 0x0870, {1})).error().why,
              "F870 is owned by drivebusd: selector of the write block at 0x1870");
    // A broadcast would rewrite them on every drive.
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Broadcast, "", 0x0876, {3})), RejectReason::DaemonOwned);
    // Reading them changes nothing: allowed.
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "pump", 0x0875, {}, 1)), RejectReason::None);
    // Owned also where this configuration does not use the block: a client reaches a block only
    // through the selectors drivebusd wrote, so its own would serve nothing.
    const auto plain = bus();
    EXPECT_EQ(reason_of(plain, request(shm::RequestKind::Write, "pump", 0x0875, {3})), RejectReason::DaemonOwned);
    EXPECT_EQ(reason_of(plain, request(shm::RequestKind::Write, "pump", 0x0871, {3})), RejectReason::DaemonOwned);
}

TEST(Admission, AWriteThroughTheBlockIsCheckedRegisterByRegister) {
    const auto b = bus(kBlocks);
    // Through F870/F871 = FA00/FA01: the command and the reference, so the lease applies.
    const auto a = admit(b, request(shm::RequestKind::Write, "pump", 0x1870, {0xC400, 1500}));
    ASSERT_TRUE(a) << a.error().why;
    EXPECT_TRUE(a->touches_control);
    EXPECT_EQ(a->registers, (std::vector<std::uint16_t>{0xFA00, 0xFA01}));
    EXPECT_EQ(a->request.pdu, rtu::Request(rtu::WriteMultipleRegisters{0x1870, rtu::RegisterValues({0xC400, 1500})}));
    // The tank's block selects FA51 and FA50, neither under the lease; FA50 takes 0-255.
    const auto tank = admit(b, request(shm::RequestKind::Write, "tank", 0x1870, {700, 12}));
    ASSERT_TRUE(tank) << tank.error().why;
    EXPECT_FALSE(tank->touches_control);
    EXPECT_EQ(tank->registers, (std::vector<std::uint16_t>{0xFA51, 0xFA50}));
    const auto high = admit(b, request(shm::RequestKind::Write, "tank", 0x1870, {700, 300}));
    ASSERT_FALSE(high);
    EXPECT_EQ(high.error().reason, RejectReason::ValueOutOfRange);
    EXPECT_EQ(high.error().register_address, 0xFA50);
    const auto over = admit(b, request(shm::RequestKind::Write, "tank", 0x1870, {1024, 1}));
    ASSERT_FALSE(over);
    EXPECT_EQ(over.error().register_address, 0xFA51);
    // A broadcast through the block reaches each drive's own targets: the pump's command.
    const auto all = admit(b, request(shm::RequestKind::Broadcast, "", 0x1870, {1000, 10}));
    ASSERT_TRUE(all) << all.error().why;
    EXPECT_TRUE(all->touches_control);
    EXPECT_EQ(all->registers, (std::vector<std::uint16_t>{0xFA00, 0xFA01, 0xFA50, 0xFA51}));
}

TEST(Admission, AReadOfTheBlockNamesTheRegistersItReturns) {
    const auto b = bus(kBlocks);
    const auto a = admit(b, request(shm::RequestKind::Read, "pump", 0x1875, {}, 2));
    ASSERT_TRUE(a) << a.error().why;
    EXPECT_EQ(a->registers, (std::vector<std::uint16_t>{0xFD00, 0xFD01}));
    EXPECT_EQ(a->request.pdu, rtu::Request(rtu::ReadHoldingRegisters{0x1875, 2}));
    const auto plain = admit(b, request(shm::RequestKind::Read, "pump", 0xFE03, {}, 1));
    ASSERT_TRUE(plain);
    EXPECT_EQ(plain->registers, (std::vector<std::uint16_t>{0xFE03}));
}

TEST(Admission, ABlockDrivebusdHasNotSetUpIsRefused) {
    // What its selectors hold is unknown to drivebusd, so nothing about the access could be checked.
    const auto plain = bus();
    for (const auto& r : {request(shm::RequestKind::Read, "pump", 0x1875, {}, 5),
                          request(shm::RequestKind::Write, "pump", 0x1870, {0xC400, 1500})}) {
        const auto a = admit(plain, r);
        ASSERT_FALSE(a);
        EXPECT_EQ(a.error().reason, RejectReason::BlockNotSetUp);
        EXPECT_EQ(a.error().register_address, r.start);
        EXPECT_NE(a.error().why.find("not set up by drivebusd on drive pump"), std::string::npos) << a.error().why;
    }
    // Set up for two slots: a third selects nothing.
    const auto b = bus(kBlocks);
    const auto a = admit(b, request(shm::RequestKind::Read, "pump", 0x1875, {}, 3));
    ASSERT_FALSE(a);
    EXPECT_EQ(a.error().reason, RejectReason::BlockNotSetUp);
    EXPECT_NE(a.error().why.find("slot 3 of the read block at 0x1875"), std::string::npos) << a.error().why;
    // The tank has a write block but no indirect poll.
    EXPECT_EQ(reason_of(b, request(shm::RequestKind::Read, "tank", 0x1875, {}, 2)), RejectReason::BlockNotSetUp);
    // A broadcast through a block that some drive has not set up.
    EXPECT_EQ(reason_of(plain, request(shm::RequestKind::Broadcast, "", 0x1870, {1, 2})), RejectReason::BlockNotSetUp);
}

TEST(Admission, TheSetUpIsWhatTheSchedulerWrites) {
    const auto b = bus(kBlocks);
    // F875-F879 then F870/F871, as the drive's set-up sends them.
    EXPECT_EQ(master::setup_writes(b.drives.at(0)),
              (std::vector<std::pair<std::uint16_t, std::uint16_t>>{
                  {0x0875, 2}, {0x0876, 1}, {0x0877, 0}, {0x0878, 0}, {0x0879, 0}, {0x0870, 1}, {0x0871, 3}}));
    EXPECT_EQ(master::setup_writes(b.drives.at(1)),
              (std::vector<std::pair<std::uint16_t, std::uint16_t>>{{0x0870, 5}, {0x0871, 4}}));
    EXPECT_TRUE(master::setup_writes(bus().drives.at(0)).empty());
}

TEST(Admission, CommandAndReferenceWritesNeedTheLease) {
    const auto b = bus();
    const auto a = admit(b, request(shm::RequestKind::Write, "pump", 0xFA01, {3000}));
    ASSERT_TRUE(a);
    EXPECT_TRUE(a->touches_control);
    EXPECT_EQ(a->request.pdu, rtu::Request(rtu::WriteSingleRegister{0xFA01, 3000}));
    EXPECT_FALSE(admit(b, request(shm::RequestKind::Write, "pump", 0xFA51, {3}))->touches_control);
}

TEST(Admission, BroadcastsMustSuitEveryDriveOnTheBus) {
    const auto b = bus();
    // FA01 is the ATV21's reference, but the ATV58 on the same bus has no such register.
    const auto a = admit(b, request(shm::RequestKind::Broadcast, "", 0xFA01, {0}));
    ASSERT_FALSE(a);
    EXPECT_EQ(a.error().reason, RejectReason::UnknownRegister);
    EXPECT_NE(a.error().why.find("atv58"), std::string::npos) << a.error().why;
}

TEST(Admission, ProbesReachAnyAddress) {
    const auto b = bus();
    auto r = request(shm::RequestKind::Probe, "", 0, {}, 0);
    r.address = 17;
    const auto a = admit(b, r);
    ASSERT_TRUE(a);
    EXPECT_EQ(a->request.address, 17);
    EXPECT_EQ(a->drive, kBroadcast);  // not a configured drive
    r.address = 0;
    EXPECT_EQ(reason_of(b, r), RejectReason::UnknownDrive);
    r.address = 248;
    EXPECT_EQ(reason_of(b, r), RejectReason::UnknownDrive);
}

TEST(Admission, LeaseOperationsStayOffTheWire) {
    const auto b = bus();
    const auto a = admit(b, request(shm::RequestKind::LeaseRenew, "pump", 0));
    ASSERT_TRUE(a);
    EXPECT_FALSE(a->on_wire);
}

// ---- leases ----

// Tokens as a source would give them, but predictable: 1, 2, 3... in the first word.
TokenSource counting_tokens() {
    return [n = std::uint64_t{0}]() mutable { return LeaseToken{++n, 0xA5A5A5A5A5A5A5A5ULL}; };
}

Holder holder(std::string name, std::int32_t pid = 0) {
    return Holder{std::move(name), pid};
}

TEST(Lease, OneHolderAtATime) {
    const auto b = bus();
    LeaseTable t(b, counting_tokens());
    const rtu::Instant t0{};
    const auto a = t.acquire(0, {}, holder("a", 11), false, t0);
    ASSERT_TRUE(a.allowed);
    EXPECT_NE(a.token, LeaseToken{}) << "taking it hands out a token";
    const auto other = t.acquire(0, {}, holder("b", 22), false, t0 + 100ms);
    EXPECT_FALSE(other.allowed);
    EXPECT_EQ(other.holder.name, "a");
    EXPECT_EQ(other.holder.pid, 11);
    EXPECT_EQ(other.token, LeaseToken{}) << "a refusal never carries the token";
    // Other drives are free.
    EXPECT_TRUE(t.acquire(1, {}, holder("b", 22), false, t0).allowed);
    // Taking it over is explicit, and moves the token: the former holder's is worth nothing.
    const auto taken = t.acquire(0, {}, holder("b", 22), true, t0 + 100ms);
    EXPECT_TRUE(taken.allowed);
    EXPECT_TRUE(taken.taken_over);
    EXPECT_NE(taken.token, a.token);
    EXPECT_FALSE(t.renew(0, a.token, t0 + 150ms).allowed);
    EXPECT_TRUE(t.renew(0, taken.token, t0 + 150ms).allowed);
}

// Finding 7 of issue 14: the lease is a capability, not a name. Whatever is published of the
// holder (its name and pid), copied into a request, and any token but the holder's, are
// refused: no write under the lease, no renewal, no release.
TEST(Lease, ACopiedIdOrAWrongTokenGetsNotPermittedAndCannotRelease) {
    const auto b = bus();
    LeaseTable t(b, counting_tokens());
    const rtu::Instant t0{};
    const auto mine = t.acquire(0, {}, holder("pump-control[11]", 11), false, t0);
    ASSERT_TRUE(mine.allowed);
    // What a snapshot publishes: who holds it, never the token.
    const auto published = t.status(0);
    EXPECT_EQ(shm::view(published.holder), "pump-control[11]");
    EXPECT_EQ(published.holder_pid, 11);
    const Holder copied{std::string(shm::view(published.holder)), published.holder_pid};
    LeaseToken wrong = mine.token;
    wrong[1] ^= 1;                                               // one bit off
    const LeaseToken guessed{mine.token[0] + 1, mine.token[1]};  // the next of a counter
    for (const auto& token : {LeaseToken{}, wrong, guessed}) {
        const auto write = t.acquire(0, token, copied, false, t0 + 10ms);
        EXPECT_FALSE(write.allowed);
        EXPECT_EQ(write.token, LeaseToken{});
        EXPECT_FALSE(t.renew(0, token, t0 + 10ms).allowed);
        EXPECT_FALSE(t.release(0, token));
        EXPECT_TRUE(t.other_holder(token).has_value()) << "nor may it broadcast to the command";
    }
    // The holder is untouched: it still holds, renews, and its lease still runs out into the
    // fallback if it stops.
    EXPECT_EQ(t.status(0).state, shm::LeaseState::Held);
    EXPECT_TRUE(t.acquire(0, mine.token, holder("pump-control[11]", 11), false, t0 + 20ms).allowed);
    EXPECT_TRUE(t.renew(0, mine.token, t0 + 30ms).allowed);
    const auto gone = t.expire(t0 + 30ms + 500ms);
    ASSERT_EQ(gone.size(), 1U);
    EXPECT_EQ(gone[0].holder.name, "pump-control[11]");
    // Once it has run out, the old token renews nothing.
    EXPECT_FALSE(t.renew(0, mine.token, t0 + 600ms).allowed);
    EXPECT_FALSE(t.release(0, mine.token));
}

// One client, one token: a lease taken while presenting the token of a lease the client holds
// on another drive gets that same token, so the client's requests can carry one token.
TEST(Lease, AClientsLeasesShareItsToken) {
    const auto b = bus();
    LeaseTable t(b, counting_tokens());
    const rtu::Instant t0{};
    const auto pump = t.acquire(0, {}, holder("a", 11), false, t0);
    const auto fan = t.acquire(1, pump.token, holder("a", 11), false, t0);
    ASSERT_TRUE(fan.allowed);
    EXPECT_EQ(fan.token, pump.token);
    EXPECT_FALSE(t.other_holder(pump.token).has_value()) << "its broadcast touches only its own leases";
    // A token presented that holds nothing (here: made up) does not become a lease's token.
    LeaseTable u(b, counting_tokens());
    const LeaseToken made_up{77, 77};
    const auto taken = u.acquire(0, made_up, holder("c", 33), false, t0);
    ASSERT_TRUE(taken.allowed);
    EXPECT_NE(taken.token, made_up);
}

TEST(Lease, RenewalKeepsItAndExpiryHappensOnceAtTheDeadline) {
    const auto b = bus();
    LeaseTable t(b, counting_tokens());
    const rtu::Instant t0{};
    const auto d = t.acquire(0, {}, holder("a", 11), false, t0);
    EXPECT_EQ(d.lease_ms, 500U);
    EXPECT_EQ(t.next_deadline(), t0 + 500ms);
    EXPECT_TRUE(t.renew(0, d.token, t0 + 400ms).allowed);
    EXPECT_TRUE(t.expire(t0 + 899ms).empty());
    const auto gone = t.expire(t0 + 900ms);
    ASSERT_EQ(gone.size(), 1U);
    EXPECT_EQ(gone[0].drive, 0U);
    EXPECT_EQ(gone[0].holder.name, "a");
    EXPECT_EQ(gone[0].fallback, config::LeaseFallback::Stop);
    EXPECT_TRUE(t.expire(t0 + 2s).empty());
    EXPECT_EQ(t.status(0).state, shm::LeaseState::Expired);
    EXPECT_EQ(t.status(0).expiries, 1U);
    EXPECT_FALSE(t.next_deadline().has_value());
    // Too late to renew; a new write takes a fresh lease.
    EXPECT_FALSE(t.renew(0, d.token, t0 + 2s).allowed);
    const auto fresh = t.acquire(0, {}, holder("b", 22), false, t0 + 2s);
    EXPECT_TRUE(fresh.allowed);
    EXPECT_FALSE(fresh.taken_over);
}

// The lease policy decides and returns actions; the caller answers, logs, publishes, writes.
TEST(LeasePolicy, ReturnsWhatToAnswerPublishLogAndWrite) {
    const auto b = bus();
    LeasePolicy p(b, counting_tokens());
    const rtu::Instant t0{};
    Origin a{1, 11, "a", shm::RequestKind::Write, 0};
    a.pid = 11;
    const Origin other{2, 22, "b", shm::RequestKind::Write, 0};
    const auto taken = p.command(0, a, false, t0);
    EXPECT_EQ(taken.status, shm::Status::Ok);
    EXPECT_TRUE(taken.republish) << "a new holder is published";
    EXPECT_EQ(taken.lease_ms, 500U);
    EXPECT_NE(taken.token, LeaseToken{});
    a.token = taken.token;
    const auto renewed = p.command(0, a, false, t0 + 100ms);
    EXPECT_FALSE(renewed.republish) << "a renewal is not";
    EXPECT_EQ(renewed.token, LeaseToken{}) << "nor is the token handed out again";
    const auto refused = p.command(0, other, false, t0 + 100ms);
    EXPECT_EQ(refused.status, shm::Status::NotPermitted);
    EXPECT_EQ(refused.holder.name, "a");
    EXPECT_EQ(refused.holder.pid, 11);
    ASSERT_TRUE(refused.note.has_value());
    EXPECT_NE(refused.note->text.find("a holds the control lease"), std::string::npos) << refused.note->text;
    EXPECT_EQ(p.command(kBroadcast, other, false, t0 + 100ms).status, shm::Status::NotPermitted);
    EXPECT_EQ(p.release(0, other).status, shm::Status::NotPermitted);
    // The holder's very client id, name and pid, without its token: refused all the same.
    Origin copy = a;
    copy.correlation = 3;
    copy.token = {};
    EXPECT_EQ(p.command(0, copy, false, t0 + 100ms).status, shm::Status::NotPermitted);
    EXPECT_EQ(p.renew(0, copy, t0 + 100ms).status, shm::Status::NotPermitted);
    const auto forged_release = p.release(0, copy);
    EXPECT_EQ(forged_release.status, shm::Status::NotPermitted);
    EXPECT_FALSE(forged_release.republish);
    EXPECT_EQ(p.status(0).state, shm::LeaseState::Held);
    // It runs out: the pump's fallback is the profile's ramp stop, written to its command word.
    const auto fallbacks = p.expire(t0 + 600ms);
    ASSERT_EQ(fallbacks.size(), 1U);
    EXPECT_EQ(fallbacks[0].note.level, log::Level::Warning);
    EXPECT_EQ(fallbacks[0].note.drive, "pump") << "the journal's DRIVE=";
    ASSERT_TRUE(fallbacks[0].write.has_value());
    EXPECT_EQ(fallbacks[0].write->address, 1);
    EXPECT_EQ(fallbacks[0].write->pdu, rtu::Request(rtu::WriteSingleRegister{0xFA00, 0xC000}));
    // The expired lease still names its last holder.
    EXPECT_EQ(p.status(0).state, shm::LeaseState::Expired);
    EXPECT_EQ(shm::view(p.status(0).holder), "a");
    EXPECT_EQ(p.status(0).holder_pid, 11);
    const auto failed = p.fallback_done(0, master::Outcome::Timeout, false);
    ASSERT_TRUE(failed.note.has_value());
    EXPECT_EQ(failed.note->level, log::Level::Error);
    EXPECT_EQ(failed.note->drive, "pump");
    EXPECT_EQ(p.status(0).fallback_ok, 0);
    // Confirmed after the failure: said once, at notice.
    const auto confirmed = p.fallback_done(0, master::Outcome::Ok, false);
    ASSERT_TRUE(confirmed.note.has_value());
    EXPECT_EQ(confirmed.note->level, log::Level::Notice);
    EXPECT_NE(confirmed.note->text.find("the fallback is confirmed, after 1 failed write(s)"), std::string::npos)
        << confirmed.note->text;
    EXPECT_EQ(p.status(0).fallback_ok, 1);
}

// The one queue limit: clients' entries up to the limit, drivebusd's own beyond it, and every
// entry leaves exactly once.
// A reload that restarts a bus carries its leases to the restarted bus's policy by drive name:
// the holder's token, renewals and deadline go on; the drives may be renumbered; a lease on a
// drive the reload removed ends with a line saying it has no fallback left.
TEST(LeasePolicy, AReloadCarriesTheLeasesByDriveName) {
    const auto before = bus();
    LeasePolicy old(before, counting_tokens());
    const rtu::Instant t0{};
    Origin a{1, 11, "a", shm::RequestKind::Write, 0};
    const auto taken = old.command(0, a, false, t0);
    ASSERT_EQ(taken.status, shm::Status::Ok);
    a.token = taken.token;
    Origin b{2, 22, "b", shm::RequestKind::Write, 1};
    const auto fan = old.command(1, b, false, t0);
    ASSERT_EQ(fan.status, shm::Status::Ok);
    const auto carried = old.carry();
    ASSERT_EQ(carried.size(), 2U);

    // The restarted bus: the pump is now the second drive, and the fan is gone.
    const auto after = bus(R"([[bus]]
name = "line1"
device = "/dev/ttyUSB0"
parity = "none"
  [[bus.drive]]
  name = "mixer"
  address = 3
  profile = "atv21"
  [[bus.drive]]
  name = "pump"
  address = 1
  profile = "atv21"
  lease = "500ms"
)");
    LeasePolicy next(after, [] {
        ADD_FAILURE() << "no token is made: the holder keeps its own";
        return LeaseToken{9, 9};
    });
    const auto notes = next.adopt(carried);
    ASSERT_EQ(notes.size(), 2U);
    EXPECT_EQ(notes[0].level, log::Level::Info);
    EXPECT_NE(notes[0].text.find("drive pump: the lease of a is kept across the reload"), std::string::npos)
        << notes[0].text;
    EXPECT_EQ(notes[1].level, log::Level::Warning);
    EXPECT_NE(notes[1].text.find("drive fan is no longer configured"), std::string::npos) << notes[1].text;

    EXPECT_EQ(next.status(1).state, shm::LeaseState::Held);
    EXPECT_EQ(next.status(0).state, shm::LeaseState::Free);
    // The holder renews and writes with its token; anyone else is refused.
    Origin moved = a;
    moved.drive = 1;
    EXPECT_EQ(next.renew(1, moved, t0 + 400ms).status, shm::Status::Ok);
    Origin other{3, 33, "c", shm::RequestKind::Write, 1};
    EXPECT_EQ(next.command(1, other, false, t0 + 450ms).status, shm::Status::NotPermitted);
    // The deadline went on from the renewal: it runs out 500 ms after it, with the fallback.
    EXPECT_TRUE(next.expire(t0 + 850ms).empty());
    const auto expired = next.expire(t0 + 901ms);
    ASSERT_EQ(expired.size(), 1U);
    EXPECT_EQ(expired[0].drive, 1U);
}

TEST(LeasePolicy, AnUnrenewedCarriedLeaseRunsOutAtItsOldDeadline) {
    const auto b = bus();
    LeasePolicy old(b, counting_tokens());
    const rtu::Instant t0{};
    const Origin a{1, 11, "a", shm::RequestKind::Write, 0};
    ASSERT_EQ(old.command(0, a, false, t0).status, shm::Status::Ok);
    LeasePolicy next(b, counting_tokens());
    (void)next.adopt(old.carry());
    EXPECT_TRUE(next.expire(t0 + 499ms).empty());
    EXPECT_EQ(next.expire(t0 + 500ms).size(), 1U);
}

TEST(PendingBook, BooksUpToTheLimitAndEveryEntryLeavesOnce) {
    PendingBook book(2);
    const auto first = book.book(Origin{}, 1);
    const auto second = book.book(Origin{}, 2);
    ASSERT_TRUE(first && second);
    EXPECT_FALSE(book.book(Origin{}, 3).has_value()) << "the limit answers QueueFull";
    const auto own = book.book_own(Origin{});
    EXPECT_EQ(book.size(), 3U);
    EXPECT_EQ(book.clients_in_flight(), 2U);
    const auto done = book.finish(*first);
    ASSERT_TRUE(done && done->route);
    EXPECT_EQ(*done->route, 1U);
    EXPECT_FALSE(book.finish(*first).has_value()) << "an entry leaves once";
    EXPECT_TRUE(book.book(Origin{}, 4).has_value());
    const auto mine = book.finish(own);
    ASSERT_TRUE(mine);
    EXPECT_TRUE(mine->origin.fallback);
    EXPECT_FALSE(mine->route.has_value());
}

TEST(Lease, ReleaseMeansNoFallback) {
    const auto b = bus();
    LeaseTable t(b, counting_tokens());
    const rtu::Instant t0{};
    const auto a = t.acquire(0, {}, holder("a", 11), false, t0);
    EXPECT_FALSE(t.release(0, {}));
    EXPECT_TRUE(t.release(0, a.token));
    EXPECT_TRUE(t.expire(t0 + 10s).empty());
    EXPECT_EQ(t.status(0).state, shm::LeaseState::Free);
    EXPECT_TRUE(shm::view(t.status(0).holder).empty());
}

TEST(Lease, BroadcastsCheckEveryDrive) {
    const auto b = bus();
    LeaseTable t(b, counting_tokens());
    EXPECT_FALSE(t.other_holder({}).has_value());
    const auto fan = t.acquire(1, {}, holder("b", 22), false, rtu::Instant{});
    EXPECT_EQ(t.other_holder({})->name, "b");
    EXPECT_FALSE(t.other_holder(fan.token).has_value());
}

// ---- payloads ----

TEST(Convert, SnapshotCarriesValuesValidityAndTimesSorted) {
    master::DriveSnapshot in;
    in.bus = "line1";
    in.name = "pump";
    in.address = 1;
    in.profile = "atv21";
    in.health = master::Health::Online;
    in.sequence = 7;
    // Each counter its own value: a copy by position would put one in another's place.
    in.counters.requests = 10;
    in.counters.replies = 11;
    in.counters.timeouts = 12;
    in.counters.bad_frames = 13;
    in.counters.retries = 14;
    in.counters.absent_transitions = 15;
    in.counters.late = 16;
    in.counters.exceptions[2] = 3;
    const rtu::Instant t{std::chrono::nanoseconds(123456789)};
    in.registers[0xFD01] = {0x6404, true, t};
    in.registers[0xFD00] = {3000, true, t};
    in.registers[0xFC91] = {0, false, {}};
    shm::DriveSnapshot out;
    fill_snapshot(in, {.published_ns = 987654321, .daemon_pid = 0}, out);
    EXPECT_TRUE(shm::compatible(out));
    EXPECT_EQ(out.published_ns, 987654321);
    EXPECT_EQ(shm::view(out.name), "pump");
    EXPECT_EQ(shm::view(out.profile), "atv21");
    EXPECT_EQ(out.health, shm::DriveHealth::Online);
    EXPECT_EQ(out.counters.requests, 10U);
    EXPECT_EQ(out.counters.replies, 11U);
    EXPECT_EQ(out.counters.timeouts, 12U);
    EXPECT_EQ(out.counters.bad_frames, 13U);
    EXPECT_EQ(out.counters.retries, 14U);
    EXPECT_EQ(out.counters.exceptions, 3U);
    EXPECT_EQ(out.counters.absent_transitions, 15U);
    EXPECT_EQ(out.counters.late, 16U);
    ASSERT_EQ(out.register_count, 3);
    EXPECT_EQ(out.registers[0].address, 0xFC91);
    EXPECT_EQ(out.registers[0].valid, 0);
    EXPECT_EQ(out.registers[1].address, 0xFD00);
    EXPECT_EQ(out.registers[1].value, 3000);
    EXPECT_EQ(out.registers[1].time_ns, 123456789);
    const auto* fd01 = out.find(0xFD01);
    ASSERT_TRUE(fd01 != nullptr);
    EXPECT_EQ(fd01->value, 0x6404);
    EXPECT_TRUE(out.find(0x1234) == nullptr);
}

TEST(Convert, ResponsesCarryReadValuesExceptionsAndIdentity) {
    master::Result r;
    r.outcome = master::Outcome::Ok;
    r.attempts = 2;
    r.response = rtu::ReadHoldingRegistersResponse{rtu::RegisterValues{1, 2, 3}};
    shm::Response out;
    fill_response(r, out);
    EXPECT_EQ(out.status, shm::Status::Ok);
    EXPECT_EQ(out.count, 3);
    EXPECT_EQ(out.values[2], 3);
    EXPECT_EQ(out.attempts, 2);

    r.outcome = master::Outcome::Exception;
    r.response = rtu::ExceptionResponse{3, rtu::ExceptionCode::IllegalDataAddress};
    shm::Response ex;
    fill_response(r, ex);
    EXPECT_EQ(ex.status, shm::Status::Exception);
    EXPECT_EQ(ex.exception, 2);

    rtu::DeviceIdentificationResponse id;
    id.objects = {{0, "Schneider Electric"}, {1, "ATV21H075M3X"}, {2, "0201"}};
    r.outcome = master::Outcome::Ok;
    r.response = id;
    shm::Response ident;
    fill_response(r, ident);
    EXPECT_EQ(shm::view(ident.identity[1]), "ATV21H075M3X");

    for (const auto& [outcome, status] : {std::pair{master::Outcome::Timeout, shm::Status::Timeout},
                                          {master::Outcome::BadFrame, shm::Status::BadFrame},
                                          {master::Outcome::EchoMismatch, shm::Status::BadFrame},
                                          {master::Outcome::BusDown, shm::Status::BusDown}}) {
        master::Result f;
        f.outcome = outcome;
        shm::Response o;
        fill_response(f, o);
        EXPECT_EQ(o.status, status);
    }
}

TEST(Convert, BusStatusListsTheDrivesAndTheirHealth) {
    const auto b = bus();
    master::BusStatus in;
    in.up = true;
    in.counters.replies = 42;
    in.reply_latency.add(std::chrono::microseconds(10));
    in.reply_latency.add(std::chrono::microseconds(30));
    shm::BusStatus out;
    fill_status(b, in, {shm::DriveHealth::Online, shm::DriveHealth::Absent},
                {.published_ns = 5'000'000'000, .daemon_pid = 4242}, out);
    EXPECT_TRUE(shm::compatible(out));
    EXPECT_EQ(out.published_ns, 5'000'000'000);
    EXPECT_EQ(out.daemon_pid, 4242);
    EXPECT_EQ(out.up, 1);
    EXPECT_EQ(shm::view(out.format), "8N1");
    EXPECT_EQ(out.drive_count, 2);
    EXPECT_EQ(out.drives_online, 1);
    EXPECT_EQ(shm::view(out.drives[1].name), "fan");
    EXPECT_EQ(out.drives[1].health, shm::DriveHealth::Absent);
    EXPECT_EQ(out.counters.replies, 42U);
    EXPECT_EQ(out.reply_latency.mean_ns, 20000);
    EXPECT_EQ(out.reply_latency.max_ns, 30000);
}

// Each counter of the bus thread reaches the shared status under its own name: distinct values
// in, the same values out, field by field as written here (not through the copy's own list).
TEST(Convert, EveryBusCounterKeepsItsName) {
    master::BusStatus in;
    auto& c = in.counters;
    c.transmissions = 1;
    c.replies = 2;
    c.timeouts = 3;
    c.crc_errors = 4;
    c.gap_errors = 5;
    c.parity_errors = 6;
    c.overflows = 7;
    c.noise = 8;
    c.foreign = 9;
    c.malformed = 10;
    c.echo_mismatches = 11;
    c.retries = 12;
    c.broadcasts = 13;
    c.queue_rejections = 14;
    c.line_down = 15;
    c.late_replies = 16;
    c.held_replies = 17;
    c.exceptions[1] = 100;
    c.exceptions[4] = 20;
    shm::BusStatus out;
    fill_status(bus(), in, {}, {}, out);
    const auto& o = out.counters;
    EXPECT_EQ(o.transmissions, 1U);
    EXPECT_EQ(o.replies, 2U);
    EXPECT_EQ(o.timeouts, 3U);
    EXPECT_EQ(o.crc_errors, 4U);
    EXPECT_EQ(o.gap_errors, 5U);
    EXPECT_EQ(o.parity_errors, 6U);
    EXPECT_EQ(o.overflows, 7U);
    EXPECT_EQ(o.noise, 8U);
    EXPECT_EQ(o.foreign, 9U);
    EXPECT_EQ(o.malformed, 10U);
    EXPECT_EQ(o.echo_mismatches, 11U);
    EXPECT_EQ(o.retries, 12U);
    EXPECT_EQ(o.broadcasts, 13U);
    EXPECT_EQ(o.queue_rejections, 14U);
    EXPECT_EQ(o.line_down, 15U);
    EXPECT_EQ(o.late_replies, 16U);
    EXPECT_EQ(o.held_replies, 17U);
    EXPECT_EQ(o.exceptions, 120U);
    EXPECT_EQ(o.requests_served, 0U) << "the ipc side's own count, filled by the publisher";
    EXPECT_EQ(o.lease_expiries, 0U);
}

}  // namespace
}  // namespace drivebus::ipc
