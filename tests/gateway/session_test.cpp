// SPDX-License-Identifier: Apache-2.0
// The gateway's pure Session on a virtual clock: no socket, no thread, no drivebusd. Bytes go
// in, effects come out, and the time is whatever the test says; so the cases a socket test
// cannot reach on time (an answer for a connection already gone, a client that stops reading
// with its read-ahead full, a poll older than a value read live) are each one step here.
#include <gtest/gtest.h>

#include <map>
#include <optional>

#include "gateway/mbap.hpp"
#include "gateway/session.hpp"

using namespace drivebus;
using namespace drivebus::gateway;
using Bytes = std::vector<std::uint8_t>;

namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kSecond = 1000 * kMs;

// Unit 1 "pump" and unit 2 "fan" on line1; unit 3 is the pump again. The snapshot of each unit
// holds what the test puts in it.
class Drives final : public gateway::Directory {
public:
    const Route* route(std::uint8_t unit) const override {
        return unit == 1 || unit == 3 ? &pump_ : unit == 2 ? &fan_ : nullptr;
    }
    std::optional<shm::DriveSnapshot> snapshot(std::uint8_t unit) const override {
        const auto it = snapshots_.find(unit == 3 ? 1 : unit);
        if (it == snapshots_.end()) {
            return std::nullopt;
        }
        return it->second;
    }
    // The drive's polled registers, read at `at`.
    void poll(std::uint8_t unit, const std::map<std::uint16_t, std::uint16_t>& values, std::int64_t at) {
        shm::DriveSnapshot s;
        s.health = shm::DriveHealth::Online;
        for (const auto& [address, value] : values) {
            s.registers[s.register_count++] = shm::RegisterSample{address, value, 1, {}, at};
        }
        snapshots_[unit] = s;
    }

private:
    Route pump_{"line1", "pump"};
    Route fan_{"line1", "fan"};
    std::map<std::uint8_t, shm::DriveSnapshot> snapshots_;
};

Bytes read_pdu(std::uint16_t start, std::uint16_t count) {
    return {0x03, static_cast<std::uint8_t>(start >> 8), static_cast<std::uint8_t>(start & 0xFF),
            static_cast<std::uint8_t>(count >> 8), static_cast<std::uint8_t>(count & 0xFF)};
}

Bytes write_pdu(std::uint16_t reg, std::uint16_t value) {
    return {0x06, static_cast<std::uint8_t>(reg >> 8), static_cast<std::uint8_t>(reg & 0xFF),
            static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value & 0xFF)};
}

Bytes adus(std::initializer_list<std::tuple<std::uint16_t, std::uint8_t, Bytes>> list) {
    Bytes all;
    for (const auto& [transaction, unit, pdu] : list) {
        const auto adu = encode(transaction, unit, pdu);
        all.insert(all.end(), adu.begin(), adu.end());
    }
    return all;
}

struct Reply {
    std::uint64_t connection = 0;
    std::uint16_t transaction = 0;
    Bytes pdu;
};

std::vector<Reply> replies(const Effects& e) {
    std::vector<Reply> out;
    for (const auto& [id, adu] : e.replies) {
        EXPECT_GE(adu.size(), kMbapHeaderSize + 1);
        out.push_back({id, static_cast<std::uint16_t>(adu[0] << 8 | adu[1]),
                       Bytes(adu.begin() + static_cast<std::ptrdiff_t>(kMbapHeaderSize), adu.end())});
    }
    return out;
}

shm::Response values(const shm::Request& request, std::int64_t reply_ns) {
    shm::Response r;
    r.count = request.count;
    for (std::uint16_t i = 0; i < request.count; ++i) {
        r.values[i] = static_cast<std::uint16_t>(request.start + i);
    }
    r.reply_ns = reply_ns;
    return r;
}

shm::LeaseToken token(std::uint64_t n) {
    return shm::LeaseToken{n, 0};
}

SessionLimits limits() {
    SessionLimits l;
    l.workers = 2;
    l.max_pipelined = 16;
    l.max_age_ns = kSecond;
    l.idle_timeout_ns = 60 * kSecond;
    return l;
}

}  // namespace

TEST(Session, AConnectionsAnswersGoInTheOrderOfItsRequestsWithOneAtATimeAtDrivebusd) {
    Drives d;
    d.poll(1, {{0xFD00, 3000}}, 0);
    Session s(limits(), d);
    s.open(1, "10.0.0.5:50122", true, token(99), 0);
    auto e = s.received(
        1, adus({{1, 1, read_pdu(0xFD00, 1)}, {2, 1, read_pdu(0xFD06, 1)}, {3, 1, read_pdu(0xFD00, 1)}}), 10 * kMs);
    auto r = replies(e);
    ASSERT_EQ(r.size(), 1U);  // the third waits behind the second, though it is in the snapshot
    EXPECT_EQ(r[0].transaction, 1);
    EXPECT_EQ(r[0].pdu, (Bytes{0x03, 0x02, 0x0B, 0xB8}));
    ASSERT_EQ(e.requests.size(), 1U);
    EXPECT_EQ(e.requests[0].request.start, 0xFD06);
    EXPECT_EQ(shm::view(e.requests[0].request.client_name), "tcp 10.0.0.5:50122");
    EXPECT_EQ(e.requests[0].request.lease_token, token(99));  // it holds no lease: its own "none"

    e = s.answered(e.requests[0].ticket, values(e.requests[0].request, 11 * kMs), 12 * kMs);
    r = replies(e);
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].transaction, 2);
    EXPECT_EQ(r[0].pdu, (Bytes{0x03, 0x02, 0xFD, 0x06}));
    EXPECT_EQ(r[1].transaction, 3);
    EXPECT_TRUE(e.requests.empty());
    EXPECT_EQ(s.stats().requests, 3U);
    EXPECT_EQ(s.stats().from_snapshot, 2U);
    EXPECT_EQ(s.stats().sent, 1U);
}

TEST(Session, AtMostWorkersRequestsAreWithDrivebusdAndTheOthersWaitTheirTurnInOrder) {
    Drives d;
    Session s(limits(), d);  // 2 workers
    std::vector<Outgoing> out;
    for (std::uint64_t id = 1; id <= 4; ++id) {
        s.open(id, "peer" + std::to_string(id), false, token(id), 0);
        auto e = s.received(id, adus({{static_cast<std::uint16_t>(id), 1, read_pdu(0xFD06, 1)}}), 0);
        out.insert(out.end(), e.requests.begin(), e.requests.end());
    }
    ASSERT_EQ(out.size(), 2U);
    EXPECT_EQ(s.stats().waiting, 2U);
    // Each answer lets the next waiting one go, in the order they came.
    auto e = s.answered(out[1].ticket, values(out[1].request, 1), 1);
    ASSERT_EQ(e.requests.size(), 1U);
    EXPECT_EQ(shm::view(e.requests[0].request.client_name), "tcp peer3");
    ASSERT_EQ(replies(e).size(), 1U);
    EXPECT_EQ(replies(e)[0].connection, 2U);
    e = s.answered(out[0].ticket, values(out[0].request, 1), 1);
    ASSERT_EQ(e.requests.size(), 1U);
    EXPECT_EQ(shm::view(e.requests[0].request.client_name), "tcp peer4");
    EXPECT_EQ(s.stats().waiting, 0U);
}

TEST(Session, AConnectionGoneLosesItsTurnAndItsAnswerIsDroppedWithoutHoldingOthers) {
    Drives d;
    auto l = limits();
    l.workers = 1;
    Session s(l, d);
    s.open(1, "a", false, token(1), 0);
    s.open(2, "b", false, token(2), 0);
    s.open(3, "c", false, token(3), 0);
    const auto a = s.received(1, adus({{1, 1, read_pdu(0xFD06, 1)}}), 0);
    ASSERT_EQ(a.requests.size(), 1U);
    EXPECT_TRUE(s.received(2, adus({{1, 1, read_pdu(0xFD06, 1)}}), 0).requests.empty());
    EXPECT_TRUE(s.received(3, adus({{1, 1, read_pdu(0xFD06, 1)}}), 0).requests.empty());
    EXPECT_EQ(s.stats().waiting, 2U);
    s.close(2);  // waiting its turn
    EXPECT_EQ(s.stats().waiting, 1U);
    s.close(1);  // its request with drivebusd
    const auto e = s.answered(a.requests[0].ticket, values(a.requests[0].request, 1), 1);
    EXPECT_TRUE(e.replies.empty());
    ASSERT_EQ(e.requests.size(), 1U);
    EXPECT_EQ(shm::view(e.requests[0].request.client_name), "tcp c");
    EXPECT_EQ(s.connections(), 1U);
    // An answer for no ticket (given twice, or unknown) changes nothing.
    EXPECT_TRUE(s.answered(a.requests[0].ticket, values(a.requests[0].request, 1), 1).replies.empty());
}

TEST(Session, TheLeaseAWriteTookIsPresentedByItsConnectionAloneOnThatBus) {
    Drives d;
    Session s(limits(), d);
    s.open(1, "a", true, token(11), 0);
    s.open(2, "b", true, token(22), 0);
    auto e = s.received(1, adus({{1, 1, write_pdu(0xFA01, 1700)}}), 0);
    ASSERT_EQ(e.requests.size(), 1U);
    EXPECT_EQ(e.requests[0].request.lease_token, token(11));
    shm::Response granted;
    granted.lease_token = token(7);
    granted.lease_ms = 1000;
    granted.reply_ns = 1;
    e = s.answered(e.requests[0].ticket, granted, 1);
    ASSERT_EQ(replies(e).size(), 1U);
    EXPECT_EQ(replies(e)[0].pdu, write_pdu(0xFA01, 1700));  // FC06 echoes its request
    // Its next request on line1, through another unit id of that bus too, presents the lease.
    e = s.received(1, adus({{2, 2, write_pdu(0xFA01, 1)}}), 2);
    ASSERT_EQ(e.requests.size(), 1U);
    EXPECT_EQ(e.requests[0].request.lease_token, token(7));
    // Another connection presents its own.
    const auto other = s.received(2, adus({{1, 1, write_pdu(0xFA01, 2)}}), 2);
    ASSERT_EQ(other.requests.size(), 1U);
    EXPECT_EQ(other.requests[0].request.lease_token, token(22));
}

TEST(Session, AValueReadLiveIsNeverFollowedByAnOlderPollOfIt) {
    Drives d;
    d.poll(2, {{450, 0}, {451, 0}, {452, 0}}, 100 * kMs);  // polled before the drive changed
    Session s(limits(), d);
    s.open(1, "a", false, token(1), 0);
    // 453 is not polled: the whole read goes to drivebusd, and 452 comes back as the drive has it.
    auto e = s.received(1, adus({{1, 2, read_pdu(452, 2)}}), 200 * kMs);
    ASSERT_EQ(e.requests.size(), 1U);
    shm::Response live;
    live.count = 2;
    live.values[0] = 333;
    live.values[1] = 7;
    live.reply_ns = 210 * kMs;
    e = s.answered(e.requests[0].ticket, live, 211 * kMs);
    ASSERT_EQ(replies(e).size(), 1U);
    // The poll of 452 is younger than max_age but older than what this client was given: to the
    // drive again, not 0 from the snapshot.
    e = s.received(1, adus({{2, 2, read_pdu(452, 1)}}), 220 * kMs);
    EXPECT_TRUE(e.replies.empty());
    ASSERT_EQ(e.requests.size(), 1U);
    e = s.answered(e.requests[0].ticket, values(e.requests[0].request, 230 * kMs), 231 * kMs);
    ASSERT_EQ(replies(e).size(), 1U);
    // 450 was not read live: its poll is served. And a poll after the live read serves 452.
    e = s.received(1, adus({{3, 2, read_pdu(450, 1)}}), 240 * kMs);
    ASSERT_EQ(replies(e).size(), 1U);
    EXPECT_EQ(replies(e)[0].pdu, (Bytes{0x03, 0x02, 0x00, 0x00}));
    d.poll(2, {{450, 111}, {451, 222}, {452, 333}}, 300 * kMs);
    e = s.received(1, adus({{4, 2, read_pdu(450, 3)}}), 310 * kMs);
    ASSERT_EQ(replies(e).size(), 1U);
    EXPECT_EQ(replies(e)[0].pdu, (Bytes{0x03, 0x06, 0x00, 0x6F, 0x00, 0xDE, 0x01, 0x4D}));
    EXPECT_EQ(s.stats().from_snapshot, 2U);
}

TEST(Session, AWriteIsReadBackThroughEveryUnitIdOfItsDriveNotAnOlderPoll) {
    Drives d;
    d.poll(1, {{0xFA01, 0}}, 100 * kMs);
    Session s(limits(), d);
    s.open(1, "a", true, token(1), 0);
    auto e = s.received(1, adus({{1, 1, write_pdu(0xFA01, 1700)}}), 150 * kMs);
    ASSERT_EQ(e.requests.size(), 1U);
    shm::Response ok;
    ok.reply_ns = 160 * kMs;
    e = s.answered(e.requests[0].ticket, ok, 170 * kMs);
    // Unit 3 reaches the same drive: its old poll is not served either.
    e = s.received(1, adus({{2, 3, read_pdu(0xFA01, 1)}}), 180 * kMs);
    EXPECT_TRUE(e.replies.empty());
    EXPECT_EQ(e.requests.size(), 1U);
}

TEST(Session, AClientThatStopsReadingIsTakenAgainWhenItReadsEvenIfItSendsNothingMore) {
    Drives d;
    d.poll(1, {{0xFD00, 3000}}, 0);
    auto l = limits();
    l.max_pipelined = 2;
    l.max_unsent = 15;  // one answer of 11 bytes fits, two do not
    Session s(l, d);
    s.open(1, "a", false, token(1), 0);
    auto e = s.received(1,
                        adus({{1, 1, read_pdu(0xFD00, 1)},
                              {2, 1, read_pdu(0xFD00, 1)},
                              {3, 1, read_pdu(0xFD00, 1)},
                              {4, 1, read_pdu(0xFD00, 1)},
                              {5, 1, read_pdu(0xFD00, 1)}}),
                        kMs);
    ASSERT_EQ(replies(e).size(), 2U);
    EXPECT_FALSE(s.reading(1));                         // its read-ahead is full and its answers unread
    EXPECT_TRUE(s.unsent(1, 22, kMs).replies.empty());  // nothing left the socket yet
    // Its client read them: the rest is answered though no byte more came from it.
    e = s.unsent(1, 0, 2 * kMs);
    auto r = replies(e);
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].transaction, 3);
    EXPECT_EQ(r[1].transaction, 4);
    e = s.unsent(1, 0, 3 * kMs);
    r = replies(e);
    ASSERT_EQ(r.size(), 1U);
    EXPECT_EQ(r[0].transaction, 5);
    EXPECT_TRUE(s.reading(1));
}

TEST(Session, IdleConnectionsAreClosedButNotWhileDrivebusdHasTheirRequest) {
    Drives d;
    d.poll(1, {{0xFD00, 1}}, 30 * kSecond);
    Session s(limits(), d);  // idle_timeout 60 s
    s.open(1, "busy", false, token(1), 0);
    s.open(2, "idle", false, token(2), 0);
    s.open(3, "talking", false, token(3), 0);
    ASSERT_EQ(s.received(1, adus({{1, 1, read_pdu(0xFD06, 1)}}), 0).requests.size(), 1U);
    ASSERT_EQ(replies(s.received(3, adus({{1, 1, read_pdu(0xFD00, 1)}}), 30 * kSecond)).size(), 1U);
    const auto e = s.tick(61 * kSecond);
    ASSERT_EQ(e.closes.size(), 1U);
    EXPECT_EQ(e.closes[0].first, 2U);
    EXPECT_EQ(e.closes[0].second, "idle: closed (idle_timeout)");
    EXPECT_EQ(s.stats().idle_closed, 1U);
    EXPECT_EQ(s.connections(), 2U);
}

TEST(Session, WhatIsRefusedHereIsAnsweredAtOnceAndNeverReachesDrivebusd) {
    Drives d;
    Session s(limits(), d);
    s.open(1, "10.0.0.9:4000", false, token(1), 0);
    const auto e =
        s.received(1, adus({{1, 1, write_pdu(0xFA01, 1)}, {2, 9, read_pdu(0xFD00, 1)}, {3, 1, Bytes{0x2B, 0x0E}}}), 0);
    EXPECT_TRUE(e.requests.empty());
    const auto r = replies(e);
    ASSERT_EQ(r.size(), 3U);
    EXPECT_EQ(r[0].pdu, (Bytes{0x86, 0x01}));  // not in write_from
    EXPECT_EQ(r[1].pdu, (Bytes{0x83, 0x0A}));  // no drive at unit 9
    EXPECT_EQ(r[2].pdu[0], 0xAB);              // a malformed FC43
    ASSERT_EQ(e.notes.size(), 1U);
    EXPECT_NE(e.notes[0].text.find("write refused from 10.0.0.9:4000 to unit 1 (pump)"), std::string::npos)
        << e.notes[0].text;
    EXPECT_EQ(e.notes[0].drive, "pump");
    EXPECT_EQ(s.stats().refused_writes, 1U);
    EXPECT_EQ(s.stats().exceptions, 3U);
}

TEST(Session, AStreamThatIsNotModbusClosesItsConnectionWithWhy) {
    Drives d;
    Session s(limits(), d);
    s.open(1, "10.0.0.9:4000", false, token(1), 0);
    const Bytes http{'G', 'E', 'T', ' ', '/', ' ', 'H', 'T', 'T', 'P', '/', '1', '.', '1', '\r', '\n'};
    const auto e = s.received(1, http, 0);
    ASSERT_EQ(e.closes.size(), 1U);
    EXPECT_EQ(e.closes[0].first, 1U);
    ASSERT_EQ(e.notes.size(), 1U);
    EXPECT_NE(e.notes[0].text.find("10.0.0.9:4000"), std::string::npos) << e.notes[0].text;
    EXPECT_EQ(s.stats().broken_streams, 1U);
    EXPECT_EQ(s.connections(), 0U);
}
