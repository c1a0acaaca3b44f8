// SPDX-License-Identifier: Apache-2.0
// The bus thread allocates nothing per poll cycle: every heap allocation made on a thread
// named "bus ..." is counted (operator new is replaced in this test program only), and after
// a warm-up the count must not move over many poll cycles of two drives. Snapshots are taken
// off the hand-over ring by the test, as the ipc thread would.
#include <execinfo.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pthread.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <new>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "sim_process.hpp"

namespace {

std::atomic<bool> g_counting{false};
std::atomic<std::uint64_t> g_bus_allocations{0};

bool on_bus_thread() noexcept {
    char name[17] = {};
    (void)::prctl(PR_GET_NAME, name, 0, 0, 0);
    return std::strncmp(name, "bus ", 4) == 0;
}

}  // namespace

void* operator new(std::size_t n) {
    if (g_counting.load(std::memory_order_relaxed) && on_bus_thread()) {
        // Where, for the first few: the failure then names the path that allocated.
        if (g_bus_allocations.fetch_add(1, std::memory_order_relaxed) < 3) {
            std::array<void*, 32> frames{};
            const int depth = ::backtrace(frames.data(), static_cast<int>(frames.size()));
            constexpr char kHeader[] = "an allocation on the bus thread, from:\n";
            (void)!::write(STDERR_FILENO, kHeader, sizeof kHeader - 1);
            ::backtrace_symbols_fd(frames.data(), depth, STDERR_FILENO);
        }
    }
    if (void* p = std::malloc(n == 0 ? 1 : n)) {
        return p;
    }
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
    return operator new(n);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t /*n*/) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t /*n*/) noexcept {
    std::free(p);
}

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// Takes `n` snapshots off the ring (or gives up at the deadline); how many it took.
std::size_t take_snapshots(bus::Handover& h, std::size_t n, std::chrono::milliseconds timeout) {
    std::size_t taken = 0;
    const auto deadline = sys::now() + timeout;
    master::DriveSnapshot s;
    while (taken < n && sys::now() < deadline) {
        pollfd p{h.ready_fd(), POLLIN, 0};
        (void)::poll(&p, 1, 100);
        h.acknowledge();
        while (taken < n && h.snapshots.try_pop(s)) {
            ++taken;
        }
    }
    return taken;
}

// The pump's block read as the bus thread polls it, with the fan beside it. With
// `commissioned` false the pump is fresh from the factory: drivebusd writes its selectors and
// the pump then awaits a reset for the whole run, its set-up tried again every 100-200 ms.
void expect_no_allocation(bool commissioned) {
    SimProcess sim({"--drive", "1:atv21", "--drive", "2:atv58"});
    if (commissioned) {
        sim.commission_read_block(1, {2, 1, 3, 4, 5});
    }
    const auto atv21 = load("atv21");
    const auto atv58 = load("atv58");
    config::BusConfig config = bus<config::BusConfig>();
    config.device = sim.link();
    config.absent_backoff_min = 100ms;
    config.absent_backoff_max = 200ms;
    auto pump = drive("pump", 1, atv21);
    pump.polls.push_back(poll(*atv21, {"FD00", "FD01", "FE03", "FE05", "FC91"}, 20ms, true));
    pump.polls.push_back(poll(*atv21, {"FA01", "FC90"}, 40ms));
    config.drives.push_back(pump);
    auto fan = drive("fan", 2, atv58);
    fan.polls.push_back(poll(*atv58, {"W450", "W451", "W452", "W453"}, 20ms));
    config.drives.push_back(fan);
    bus::BusLoop loop(config, master::EngineCallbacks{});
    ASSERT_TRUE(loop.start().has_value());
    // Warm-up: the port is opened, the block set up (or found to await a reset), every register
    // seen once.
    ASSERT_EQ(take_snapshots(loop.handover(), 20, 20s), 20U);
    const auto requests = [&] {
        const auto stats = sim.command("stats");
        const auto at = stats.find("requests=");
        return at == std::string::npos ? 0ULL : std::stoull(stats.substr(at + 9));
    };
    const auto before = requests();
    g_counting = true;
    const auto taken = take_snapshots(loop.handover(), 100, 30s);
    g_counting = false;
    const auto during = requests() - before;
    loop.stop();
    ASSERT_EQ(taken, 100U);
    EXPECT_EQ(g_bus_allocations.load(), 0U) << "heap allocations on the bus thread over " << taken << " poll cycles";
    // The pump was on the line meanwhile (polled, or its set-up tried again), beside the fan's
    // one read per snapshot.
    EXPECT_GT(during, taken + 20) << during << " requests over " << taken << " snapshots";
}

TEST(BusThread, AllocatesNothingPerPollCycle) {
    expect_no_allocation(true);
}

// A drive that awaits a reset is tried again with back-off for as long as nobody resets it:
// hours, on a board nobody visits. Its set-up allocates nothing either.
TEST(BusThread, AllocatesNothingWhileADriveAwaitsAReset) {
    expect_no_allocation(false);
}

}  // namespace
}  // namespace drivebus::test
