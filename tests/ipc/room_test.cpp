// SPDX-License-Identifier: Apache-2.0
// Control is never locked out: however many readers keep however many requests in flight, a
// write to a drive's command or reference finds room in the queue, and no client holds more
// than its share. Pure: PendingBook and IntakeCore with a bus that never answers.
#include <gtest/gtest.h>

#include "config/config.hpp"
#include "ipc/intake_core.hpp"
#include "read_bus.hpp"

namespace drivebus::ipc {
namespace {

using namespace std::chrono_literals;

// A client on a port of its own (its number).
Origin from(std::uint64_t client) {
    Origin o;
    o.client = client;
    o.port = client;
    return o;
}

TEST(QueueRoom, ReadersFillOnlyTheSharedRoomEachWithinItsShare) {
    PendingBook book(64);
    EXPECT_EQ(book.shared_room(), 48U);
    EXPECT_EQ(book.share(), 12U);
    // Six clients try to keep 12 reads each in flight: 72 against a room of 48.
    std::size_t booked = 0;
    for (int round = 0; round < 12; ++round) {
        for (std::uint64_t client = 1; client <= 6; ++client) {
            booked += book.book(from(client), 0).has_value() ? 1U : 0U;
        }
    }
    EXPECT_EQ(booked, 48U);
    EXPECT_FALSE(book.book(from(7), 0).has_value()) << "a plain request of another client: the shared room is full";
    // The control room takes a controller's writes.
    const auto take = book.book(from(7), 0, Room::Control);
    ASSERT_TRUE(take.has_value());
    EXPECT_TRUE(book.book(from(7), 0, Room::Control).has_value());
    // And once a reader's answer comes, its room is free again.
    ASSERT_TRUE(book.finish(1).has_value());
    EXPECT_TRUE(book.book(from(8), 0).has_value());
    // One client alone never holds more than its share, whatever room it asks for.
    PendingBook alone(64);
    std::size_t mine = 0;
    for (int i = 0; i < 100; ++i) {
        mine += alone.book(from(1), 0, i % 2 == 0 ? Room::Shared : Room::Control).has_value() ? 1U : 0U;
    }
    EXPECT_EQ(mine, 12U);
    EXPECT_EQ(alone.clients_in_flight(), 12U);
}

// The share is the port's: a client that writes another id in each request still holds one.
TEST(QueueRoom, AClientThatChangesItsIdWithEachRequestStillHasOneShare) {
    PendingBook book(64);
    std::size_t booked = 0;
    for (std::uint64_t id = 1; id <= 48; ++id) {
        Origin o = from(id);
        o.port = 77;
        booked += book.book(o, 0).has_value() ? 1U : 0U;
    }
    EXPECT_EQ(booked, book.share());
    EXPECT_TRUE(book.book(from(5), 0).has_value()) << "another port still has its share";
}

// A withdrawal finds a request only through the port that sent it.
TEST(QueueRoom, OnlyThePortThatSentARequestFindsIt) {
    PendingBook book(64);
    Origin o = from(5);
    o.correlation = 9;
    const auto id = book.book(o, 0);
    ASSERT_TRUE(id.has_value());
    EXPECT_EQ(book.find(5, 5, 9), id);
    EXPECT_EQ(book.find(6, 5, 9), std::nullopt) << "the same client id and correlation, from another port";
}

TEST(QueueRoom, SmallLimitsStillServeOneClient) {
    PendingBook two(2);
    EXPECT_TRUE(two.book(from(1), 0).has_value());
    EXPECT_TRUE(two.book(from(1), 0).has_value());
    EXPECT_FALSE(two.book(from(1), 0).has_value());
    PendingBook one(1);
    EXPECT_TRUE(one.book(from(1), 0).has_value());
}

shm::Request request(shm::RequestKind kind, std::uint64_t client, std::uint16_t start, std::uint16_t value = 0) {
    shm::Request r;
    r.size = sizeof r;
    r.kind = kind;
    r.client = client;
    shm::assign(r.drive, "pump");
    shm::assign(r.client_name, "client-" + std::to_string(client));
    r.start = start;
    r.count = 1;
    r.values[0] = value;
    return r;
}

// The flood at the intake: six readers with 12 reads each in flight, on a bus that
// answers nothing meanwhile. A controller's first write of the command, and of the reference,
// are taken at once, and the first takes the lease; a write of another register is not
// (it waits for room like a read).
TEST(QueueRoom, AControllerCommandsAtOnceWhileReadersFlood) {
    const auto bus = test::read_bus(test::pump_toml());
    ASSERT_FALSE(HasFailure());
    LeasePolicy leases(bus, [n = std::uint64_t{0}]() mutable { return shm::LeaseToken{++n, 3}; });
    std::size_t submitted = 0;
    IntakeCore intake(bus, leases, [&](const master::ClientRequest&) {
        ++submitted;
        return true;
    });
    const rtu::Instant now{std::chrono::seconds(5)};
    int full = 0;
    for (int k = 0; k < 12; ++k) {
        for (std::uint64_t reader = 1; reader <= 6; ++reader) {
            RouteId route = 0;
            const auto a = intake.accept(request(shm::RequestKind::Read, reader, 0xFD00), route, true, now);
            full += a && a->status == shm::Status::QueueFull ? 1 : 0;
        }
    }
    EXPECT_EQ(full, 72 - 48) << "the readers get QueueFull past the shared room";
    RouteId route = 0;
    EXPECT_FALSE(intake.accept(request(shm::RequestKind::Write, 9, 0xFA01, 2000), route, true, now).has_value())
        << "the reference: booked for the bus";
    auto command = request(shm::RequestKind::Write, 9, 0xFA00, 0xC400);
    command.lease_token = {1, 3};  // the token the first write took
    EXPECT_FALSE(intake.accept(command, route, true, now).has_value()) << "the command: booked for the bus";
    EXPECT_EQ(leases.status(0).state, shm::LeaseState::Held);
    EXPECT_EQ(leases.status(0).holder_pid, 0);
    EXPECT_EQ(shm::view(leases.status(0).holder), "client-9");
    const auto other = intake.accept(request(shm::RequestKind::Write, 9, 0xFA51, 1), route, true, now);
    ASSERT_TRUE(other.has_value());
    EXPECT_EQ(other->status, shm::Status::QueueFull);
    EXPECT_EQ(submitted, 50U);
}

// At the intake, the port comes from the route (iceoryx: the client's response queue). One
// port rotating its client id gets QueueFull past its share, while a controller on another
// port commands at once.
TEST(QueueRoom, ARotatingIdFloodFromOnePortIsHeldToItsShare) {
    const auto bus = test::read_bus(test::pump_toml());
    ASSERT_FALSE(HasFailure());
    LeasePolicy leases(bus, [n = std::uint64_t{0}]() mutable { return shm::LeaseToken{++n, 3}; });
    IntakeCore intake(
        bus, leases, [](const master::ClientRequest&) { return true; }, {}, [](RouteId route) { return route; });
    const rtu::Instant now{std::chrono::seconds(5)};
    int full = 0;
    for (std::uint64_t id = 1; id <= 48; ++id) {
        RouteId port = 1;
        const auto a = intake.accept(request(shm::RequestKind::Read, id, 0xFD00), port, true, now);
        full += a && a->status == shm::Status::QueueFull ? 1 : 0;
    }
    EXPECT_EQ(full, 48 - static_cast<int>(intake.book().share()));
    RouteId controller = 2;
    EXPECT_FALSE(intake.accept(request(shm::RequestKind::Write, 1000, 0xFA01, 2000), controller, true, now))
        << "the controller's reference: booked for the bus";
    RouteId reader = 3;
    EXPECT_FALSE(intake.accept(request(shm::RequestKind::Read, 1001, 0xFD00), reader, true, now))
        << "a reader on a third port: the shared room has room";
}

}  // namespace
}  // namespace drivebus::ipc
