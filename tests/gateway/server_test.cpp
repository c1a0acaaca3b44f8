// SPDX-License-Identifier: Apache-2.0
// The gateway's server over real TCP sockets on loopback, with a fake drivebusd behind it:
// order, fairness between connections, leases per connection, access and the bounds.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <thread>

#include "gateway/mbap.hpp"
#include "gateway/server.hpp"
#include "sim_process.hpp"
#include "sys/event_fd.hpp"
#include "sys/posix.hpp"
#include "tcp_peer.hpp"

using namespace drivebus;
using namespace drivebus::gateway;
using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using drivebus::gateway::test::Peer;

namespace {

std::int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(sys::now().time_since_epoch()).count();
}

// drivebusd as the server sees it: unit 1 "pump" polls FD00 (always fresh), unit 2 "fan";
// reads of anything else answer start + i; writes hold a lease per drive like drivebusd's.
class FakeBackend final : public Backend {
public:
    // Unit 3 is the pump again, under another unit id.
    const Route* route(std::uint8_t unit) const override {
        return unit == 1 || unit == 3 ? &pump_ : unit == 2 ? &fan_ : nullptr;
    }
    std::optional<shm::DriveSnapshot> snapshot(std::uint8_t unit) const override {
        if (unit < 1 || unit > 3) {
            return std::nullopt;
        }
        shm::DriveSnapshot s;
        s.health = shm::DriveHealth::Online;
        s.register_count = 1;
        s.registers[0] = shm::RegisterSample{0xFD00, 3000, 1, {}, polled_at.value_or(now_ns())};
        return s;
    }
    // Answered in the next dispatch(), as libdrivebus answers; a blocked unit's requests wait
    // until it is let go.
    void submit(std::uint8_t unit, const shm::Request& request, Done done) override {
        std::lock_guard lock(mutex);
        seen.push_back(request);
        changed.notify_all();
        pending.push_back({unit, request, std::move(done)});
        ready.signal();
    }
    std::vector<int> descriptors() const override { return {ready.fd()}; }
    void dispatch() override {
        ready.drain();
        std::vector<Pending> now;
        {
            std::lock_guard lock(mutex);
            std::erase_if(pending, [&](Pending& p) {
                if (p.unit == blocked_unit) {
                    return false;
                }
                now.push_back(std::move(p));
                return true;
            });
        }
        for (auto& p : now) {
            p.done(answer(p.unit, p.request));
        }
    }
    // When the snapshot's FD00 was polled: now at each call unless set.
    std::optional<std::int64_t> polled_at;
    // From the test's thread.
    void block(int unit) {
        std::lock_guard lock(mutex);
        blocked_unit = unit;
        changed.notify_all();
        ready.signal();
    }
    bool wait_seen(std::size_t n) {
        std::unique_lock lock(mutex);
        return changed.wait_for(lock, 10s, [&] { return seen.size() >= n; });
    }
    std::vector<shm::Request> requests() {
        std::lock_guard lock(mutex);
        return seen;
    }

private:
    struct Pending {
        std::uint8_t unit = 0;
        shm::Request request;
        Done done;
    };
    shm::Response answer(std::uint8_t unit, const shm::Request& request) {
        std::lock_guard lock(mutex);
        shm::Response r;
        r.count = request.count;
        if (request.kind == shm::RequestKind::Read) {
            for (std::uint16_t i = 0; i < request.count; ++i) {
                r.values[i] = static_cast<std::uint16_t>(request.start + i);
            }
        } else if (request.kind == shm::RequestKind::Write) {
            auto& holder = holders[unit];
            if (holder != shm::LeaseToken{} && holder != request.lease_token) {
                r.status = shm::Status::NotPermitted;
                shm::assign(r.lease_holder, "someone");
            } else if (holder == shm::LeaseToken{}) {
                holder = shm::LeaseToken{++next_token, 0};
                r.lease_token = holder;
                r.lease_ms = 1000;
            } else {
                r.lease_ms = 1000;
            }
        }
        return r;
    }

    Route pump_{"line1", "pump"};
    Route fan_{"line1", "fan"};
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<shm::Request> seen;
    std::map<int, shm::LeaseToken> holders;
    std::uint64_t next_token = 100;
    int blocked_unit = -1;
    std::vector<Pending> pending;
    sys::EventFd ready{"eventfd of the fake drivebusd"};
};

// Lets the fake's hung drive go when a test ends, even by a failed assertion.
class Unblock {
public:
    explicit Unblock(FakeBackend& backend) : backend_(backend) {}
    ~Unblock() { backend_.block(-1); }
    Unblock(const Unblock&) = delete;
    Unblock& operator=(const Unblock&) = delete;
    Unblock(Unblock&&) = delete;
    Unblock& operator=(Unblock&&) = delete;

private:
    FakeBackend& backend_;
};

class Running {
public:
    Running(Config config, Backend& backend) : server(std::move(config), backend), thread([this] { server.run(); }) {}
    ~Running() {
        server.stop();
        thread.join();
    }
    Running(const Running&) = delete;
    Running& operator=(const Running&) = delete;
    Running(Running&&) = delete;
    Running& operator=(Running&&) = delete;
    Server server;
    std::thread thread;
};

Config loopback() {
    Config c;
    c.listen = Endpoint{"127.0.0.1", 0};
    c.workers = 2;
    c.write_from = {*Network::parse("127.0.0.0/8")};
    return c;
}

const Bytes kReadPolled{0x03, 0xFD, 0x00, 0x00, 0x01};
const Bytes kReadFd06{0x03, 0xFD, 0x06, 0x00, 0x01};
const Bytes kWriteFa01{0x06, 0xFA, 0x01, 0x0B, 0xB8};

}  // namespace

TEST(GatewayServer, PipelinedRequestsAreAnsweredInTheOrderTheyCame) {
    FakeBackend backend;
    Running r(loopback(), backend);
    Peer peer(r.server.port());
    ASSERT_TRUE(peer.connected());
    Bytes three = encode(1, 1, kReadPolled);
    for (const auto& adu : {encode(2, 1, kReadFd06), encode(3, 1, kReadPolled)}) {
        three.insert(three.end(), adu.begin(), adu.end());
    }
    peer.send(three);
    const auto a = peer.answer();
    const auto b = peer.answer();
    const auto c = peer.answer();
    ASSERT_TRUE(a && b && c);
    EXPECT_EQ(a->first, 1);
    EXPECT_EQ(a->second, (Bytes{0x03, 0x02, 0x0B, 0xB8}));  // the snapshot's 3000
    EXPECT_EQ(b->first, 2);
    EXPECT_EQ(b->second, (Bytes{0x03, 0x02, 0xFD, 0x06}));  // from drivebusd
    EXPECT_EQ(c->first, 3);
    const auto stats = r.server.stats();
    EXPECT_EQ(stats.requests, 3U);
    EXPECT_EQ(stats.from_snapshot, 2U);
    EXPECT_EQ(stats.sent, 1U);
    ASSERT_EQ(backend.requests().size(), 1U);
    EXPECT_EQ(shm::view(backend.requests()[0].client_name).substr(0, 14), "tcp 127.0.0.1:");
}

TEST(GatewayServer, ADriveThatHangsHoldsOnlyTheConnectionsWaitingForIt) {
    FakeBackend backend;
    Running r(loopback(), backend);
    const Unblock unblock(backend);
    backend.block(2);
    Peer slow(r.server.port());
    Peer other(r.server.port());
    slow.request(1, 2, kReadFd06);
    slow.request(2, 1, kReadPolled);  // behind its own head
    ASSERT_TRUE(backend.wait_seen(1));
    other.request(7, 1, kReadFd06);
    const auto served = other.answer();
    ASSERT_TRUE(served);
    EXPECT_EQ(served->first, 7);
    EXPECT_EQ(served->second, (Bytes{0x03, 0x02, 0xFD, 0x06}));
    other.request(8, 1, kReadPolled);
    ASSERT_TRUE(other.answer());
    backend.block(-1);
    const auto first = slow.answer();
    const auto second = slow.answer();
    ASSERT_TRUE(first && second);
    EXPECT_EQ(first->first, 1);
    EXPECT_EQ(second->first, 2);
}

TEST(GatewayServer, AConnectionsLeaseIsItsOwnAndIsNotReleasedWhenItGoes) {
    FakeBackend backend;
    Running r(loopback(), backend);
    Peer holder(r.server.port());
    Peer intruder(r.server.port());
    holder.request(1, 1, kWriteFa01);
    ASSERT_EQ(holder.answer()->second, kWriteFa01);
    holder.request(2, 1, kWriteFa01);
    ASSERT_EQ(holder.answer()->second, kWriteFa01);
    intruder.request(3, 1, kWriteFa01);
    const auto refused = intruder.answer();
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->second, (Bytes{0x86, 0x06}));  // busy: another client holds the lease
    holder.close();
    intruder.request(4, 1, kWriteFa01);
    EXPECT_EQ(intruder.answer()->second, (Bytes{0x86, 0x06}));  // still held until it runs out

    const auto seen = backend.requests();
    ASSERT_EQ(seen.size(), 4U);
    EXPECT_NE(seen[0].lease_token, shm::LeaseToken{});  // a random one, that no lease has
    EXPECT_EQ(seen[1].lease_token, (shm::LeaseToken{101, 0}));
    EXPECT_NE(seen[2].lease_token, seen[1].lease_token);
    EXPECT_NE(seen[2].lease_token, seen[0].lease_token);
    for (const auto& s : seen) {
        EXPECT_EQ(s.kind, shm::RequestKind::Write);  // no release when the holder went
    }
    EXPECT_EQ(r.server.stats().refused_writes, 2U);
}

TEST(GatewayServer, WritesFromAnUnlistedSourceNeverReachDrivebusd) {
    FakeBackend backend;
    auto config = loopback();
    config.write_from = {*Network::parse("10.0.0.0/8")};
    Running r(config, backend);
    Peer peer(r.server.port());
    peer.request(1, 1, kWriteFa01);
    EXPECT_EQ(peer.answer()->second, (Bytes{0x86, 0x01}));
    peer.request(2, 1, Bytes{0x10, 0xFA, 0x00, 0x00, 0x01, 0x02, 0x00, 0x00});
    EXPECT_EQ(peer.answer()->second, (Bytes{0x90, 0x01}));
    peer.request(3, 1, kReadFd06);
    EXPECT_EQ(peer.answer()->second, (Bytes{0x03, 0x02, 0xFD, 0x06}));
    ASSERT_EQ(backend.requests().size(), 1U);
    EXPECT_EQ(backend.requests()[0].kind, shm::RequestKind::Read);
    EXPECT_EQ(r.server.stats().refused_writes, 2U);
}

TEST(GatewayServer, UnknownUnitsAndFunctionsGetTheirExceptions) {
    FakeBackend backend;
    Running r(loopback(), backend);
    Peer peer(r.server.port());
    peer.request(1, 99, kReadPolled);
    EXPECT_EQ(peer.answer()->second, (Bytes{0x83, 0x0A}));
    peer.request(2, 1, Bytes{0x01, 0x00, 0x00, 0x00, 0x08});
    EXPECT_EQ(peer.answer()->second, (Bytes{0x81, 0x01}));
    peer.request(3, 1, Bytes{0x03, 0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(peer.answer()->second, (Bytes{0x83, 0x03}));
    EXPECT_TRUE(backend.requests().empty());
}

TEST(GatewayServer, ConnectionsPastTheLimitOrFromOutsideAreClosedAtOnce) {
    FakeBackend backend;
    auto config = loopback();
    config.max_connections = 2;
    Running r(config, backend);
    Peer a(r.server.port());
    Peer b(r.server.port());
    a.request(1, 1, kReadPolled);
    ASSERT_TRUE(a.answer());
    b.request(1, 1, kReadPolled);
    ASSERT_TRUE(b.answer());
    Peer c(r.server.port());
    EXPECT_TRUE(c.closed_by_server());
    a.request(2, 1, kReadPolled);
    EXPECT_TRUE(a.answer());
    EXPECT_EQ(r.server.stats().refused_connections, 1U);

    FakeBackend other;
    auto outside = loopback();
    outside.allow_from = {*Network::parse("192.168.0.0/16")};
    Running s(outside, other);
    Peer d(s.server.port());
    EXPECT_TRUE(d.closed_by_server());
}

TEST(GatewayServer, IdleAndNonModbusConnectionsAreClosed) {
    FakeBackend backend;
    auto config = loopback();
    config.idle_timeout = 100ms;
    Running r(config, backend);
    Peer idle(r.server.port());
    idle.request(1, 1, kReadPolled);
    ASSERT_TRUE(idle.answer());
    EXPECT_TRUE(idle.closed_by_server());
    EXPECT_TRUE(drivebus::test::wait_until([&] { return r.server.stats().idle_closed == 1; }, 5s));

    Peer http(r.server.port());
    const std::string get = "GET / HTTP/1.1\r\nHost: x\r\n\r\n";
    http.send(Bytes(get.begin(), get.end()));
    EXPECT_TRUE(http.closed_by_server());
    EXPECT_EQ(r.server.stats().broken_streams, 1U);
}

TEST(GatewayServer, AClientThatNeverReadsItsAnswersHoldsNobodyElse) {
    FakeBackend backend;
    Running r(loopback(), backend);
    Peer deaf(r.server.port());
    const int small = 4096;
    ::setsockopt(deaf.fd(), SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    // Requests until its own send buffer is full: the server has stopped reading from it.
    const Bytes adu = encode(1, 1, Bytes{0x03, 0xFD, 0x00, 0x00, 0x01});
    std::size_t sent = 0;
    for (;;) {
        const auto n = ::send(deaf.fd(), adu.data(), adu.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n < 0) {
            ASSERT_TRUE(errno == EAGAIN || errno == EWOULDBLOCK) << std::strerror(errno);
            break;
        }
        sent += static_cast<std::size_t>(n);
        ASSERT_LT(sent, 64U * 1024 * 1024) << "the server kept reading from a client that reads nothing";
    }
    Peer other(r.server.port());
    other.request(5, 1, kReadFd06);
    const auto a = other.answer();
    ASSERT_TRUE(a);
    EXPECT_EQ(a->first, 5);
    // What it holds for the deaf client is bounded: far fewer requests taken than sent.
    EXPECT_LT(r.server.stats().requests, sent / adu.size());
}

TEST(GatewayServer, AClientThatResetsWhileItsRequestWaitsIsDroppedAtOnce) {
    FakeBackend backend;
    auto config = loopback();
    config.max_pipelined = 1;  // its second request stays unread: the server stops watching it
    Running r(config, backend);
    const Unblock unblock(backend);
    backend.block(2);
    {
        Peer gone(r.server.port());
        gone.request(1, 2, kReadFd06);
        ASSERT_TRUE(backend.wait_seen(1));
        gone.request(2, 2, kReadFd06);
        const linger abortive{1, 0};  // close() sends a reset
        ::setsockopt(gone.fd(), SOL_SOCKET, SO_LINGER, &abortive, sizeof abortive);
    }
    EXPECT_TRUE(drivebus::test::wait_until([&] { return r.server.stats().open == 0; }, 5s))
        << "the connection is still open while its drive hangs";
    backend.block(-1);
}

TEST(GatewayServer, AtMostWorkersRequestsAreWithDrivebusdAndTheOthersWaitTheirTurnInOrder) {
    FakeBackend backend;
    Running r(loopback(), backend);  // workers = 2
    const Unblock unblock(backend);
    backend.block(2);
    Peer a(r.server.port());
    Peer b(r.server.port());
    Peer c(r.server.port());
    Peer d(r.server.port());
    a.request(1, 2, kReadFd06);
    b.request(2, 2, kReadFd06);
    ASSERT_TRUE(backend.wait_seen(2));
    c.request(3, 1, kReadFd06);  // a drive that answers, but both requests under way are a's and b's
    ASSERT_TRUE(drivebus::test::wait_until([&] { return r.server.stats().waiting == 1; }, 10s));
    d.request(4, 1, kReadFd06);
    ASSERT_TRUE(drivebus::test::wait_until([&] { return r.server.stats().waiting == 2; }, 10s));
    EXPECT_EQ(backend.requests().size(), 2U) << "more than `workers` requests went to drivebusd";
    backend.block(-1);
    for (auto* p : {&a, &b, &c, &d}) {
        const auto answered = p->answer();
        ASSERT_TRUE(answered);
        EXPECT_EQ(answered->second, (Bytes{0x03, 0x02, 0xFD, 0x06}));
    }
    const auto seen = backend.requests();
    ASSERT_EQ(seen.size(), 4U);
    // c's went before d's: the order they came in.
    const auto name_of = [](const Peer& p) {
        sockaddr_in local{};
        socklen_t length = sizeof local;
        ::getsockname(p.fd(), reinterpret_cast<sockaddr*>(&local), &length);
        return "tcp 127.0.0.1:" + std::to_string(ntohs(local.sin_port));
    };
    EXPECT_EQ(shm::view(seen[2].client_name), name_of(c));
    EXPECT_EQ(shm::view(seen[3].client_name), name_of(d));
    EXPECT_EQ(r.server.stats().waiting, 0U);
    EXPECT_EQ(r.server.stats().sent, 4U);
}

TEST(GatewayServer, AWriteThroughOneUnitIdIsNotReadBackStaleThroughAnother) {
    FakeBackend backend;
    backend.polled_at = now_ns();  // polled once, before the write
    Running r(loopback(), backend);
    Peer peer(r.server.port());
    peer.request(1, 3, kReadPolled);
    EXPECT_EQ(peer.answer()->second, (Bytes{0x03, 0x02, 0x0B, 0xB8}));  // the snapshot's 3000
    peer.request(2, 1, Bytes{0x06, 0xFD, 0x00, 0x12, 0x34});
    EXPECT_EQ(peer.answer()->second, (Bytes{0x06, 0xFD, 0x00, 0x12, 0x34}));
    // The same drive under unit 3: the poll is older than the write, so the read goes to the drive.
    peer.request(3, 3, kReadPolled);
    EXPECT_EQ(peer.answer()->second, (Bytes{0x03, 0x02, 0xFD, 0x00}));  // the fake drive's answer
    EXPECT_EQ(r.server.stats().from_snapshot, 1U);
}
