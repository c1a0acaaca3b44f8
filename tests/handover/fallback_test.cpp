// SPDX-License-Identifier: Apache-2.0
// A lease fallback on the real bus thread against the simulator: while the drive's replies are
// spoiled it is retried (never answered as done); once a reply comes through it is answered
// Ok; and when the drive falls silent it is given up once the drive is found absent.
#include <gtest/gtest.h>
#include <poll.h>

#include <optional>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// The hand-over's answer for `id`, waiting up to `timeout`; other entries are dropped.
std::optional<master::Finished> answer_for(bus::Handover& h, std::uint64_t id, std::chrono::milliseconds timeout) {
    const auto deadline = sys::now() + timeout;
    do {
        pollfd p{h.ready_fd(), POLLIN, 0};
        (void)::poll(&p, 1, 50);
        h.acknowledge();
        master::Finished f;
        while (h.results.try_pop(f)) {
            if (f.id == id) {
                return f;
            }
        }
        master::DriveSnapshot s;
        while (h.snapshots.try_pop(s)) {
        }
    } while (sys::now() < deadline);
    return std::nullopt;
}

master::ClientRequest stop_word(std::uint64_t id) {
    master::ClientRequest r{0, id, {1, rtu::WriteSingleRegister{0xFA00, 0xC000}}};
    r.fallback = true;
    return r;
}

TEST(Fallback, RetriedUntilTheDriveAcknowledgesItAndGivenUpWhenTheDriveIsAbsent) {
    SimProcess sim({"--drive", "1:atv21"});
    const auto atv21 = load("atv21");
    config::BusConfig config = bus<config::BusConfig>();
    config.device = sim.link();
    auto pump = drive("pump", 1, atv21);
    pump.polls.push_back(poll(*atv21, {"FD00"}, 50ms));
    config.drives.push_back(pump);
    bus::BusLoop loop(config, master::EngineCallbacks{});
    ASSERT_TRUE(loop.start().has_value());
    ASSERT_TRUE(wait_until([&] { return loop.status().counters.replies > 2; }, 10s));

    // Every reply spoiled: the write reaches the drive, but is never acknowledged.
    ASSERT_EQ(sim.command("fault 1 crc=1").rfind("ok", 0), 0U);
    ASSERT_TRUE(loop.submit(stop_word(7)).has_value());
    const auto crc_before = loop.status().counters.crc_errors;
    // Several spoiled attempts (the write's retries, then its next tries, and the polls')...
    ASSERT_TRUE(wait_until([&] { return loop.status().counters.crc_errors > crc_before + 8; }, 10s));
    // ...and no answer for it meanwhile.
    EXPECT_FALSE(answer_for(loop.handover(), 7, 0ms).has_value()) << "answered although never acknowledged";
    ASSERT_EQ(sim.command("clear").rfind("ok", 0), 0U);
    const auto done = answer_for(loop.handover(), 7, 10s);
    ASSERT_TRUE(done.has_value()) << "never answered once the replies came through";
    EXPECT_EQ(done->outcome, master::Outcome::Ok);
    EXPECT_EQ(sim.command("get 1 FA00"), "ok 49152");

    // A drive that falls silent: the fallback is given up when the polls find it absent.
    ASSERT_EQ(sim.command("fault 1 drop=1").rfind("ok", 0), 0U);
    ASSERT_TRUE(loop.submit(stop_word(8)).has_value());
    const auto gone = answer_for(loop.handover(), 8, 20s);
    ASSERT_TRUE(gone.has_value()) << "a fallback for an absent drive is never given up";
    EXPECT_EQ(gone->outcome, master::Outcome::Timeout);
    loop.stop();
}

}  // namespace
}  // namespace drivebus::test
