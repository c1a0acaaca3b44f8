// SPDX-License-Identifier: Apache-2.0
// The master's bus thread on a real pty against drivebus-sim, with real time, real threads
// and the simulator's fault injection. Every wait is a condition with a deadline.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/ioctl.h>
#include <termios.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "rtu/codec.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using master::Health;

// W450-W459 hold these; a corrupted reply that was accepted would show another value.
constexpr std::uint16_t kFanValue(std::uint16_t i) {
    return static_cast<std::uint16_t>(1000 + 111 * i);
}

class Recorder {
public:
    master::EngineCallbacks callbacks() {
        master::EngineCallbacks c;
        c.snapshot = [this](const master::DriveSnapshot& s) {
            const std::lock_guard lock(mutex_);
            latest_[std::string(s.name)] = s;
            ++count_[std::string(s.name)];
            for (const auto& [address, v] : s.registers) {
                if (v.valid && s.name == "fan" && v.value != kFanValue(static_cast<std::uint16_t>(address - 450))) {
                    ++wrong_values_;
                }
            }
        };
        return c;
    }
    std::optional<master::DriveSnapshot> latest(const std::string& name) const {
        const std::lock_guard lock(mutex_);
        const auto it = latest_.find(name);
        return it == latest_.end() ? std::nullopt : std::optional(it->second);
    }
    std::size_t count(const std::string& name) const {
        const std::lock_guard lock(mutex_);
        const auto it = count_.find(name);
        return it == count_.end() ? 0 : it->second;
    }
    std::size_t wrong_values() const {
        const std::lock_guard lock(mutex_);
        return wrong_values_;
    }

private:
    mutable std::mutex mutex_;
    std::map<std::string, master::DriveSnapshot> latest_;
    std::map<std::string, std::size_t> count_;
    std::size_t wrong_values_ = 0;
};

class BusLoopTest : public ::testing::Test {
protected:
    std::unique_ptr<SimProcess> sim =
        std::make_unique<SimProcess>(std::vector<std::string>{"--drive", "1:atv21", "--drive", "2:atv58"});
    std::shared_ptr<const Profile> atv21 = load("atv21");
    std::shared_ptr<const Profile> atv58 = load("atv58");
    config::BusConfig config = bus<config::BusConfig>();
    Recorder recorder;
    std::unique_ptr<bus::BusLoop> loop;

    void SetUp() override {
        for (std::uint16_t i = 0; i < 10; ++i) {
            ASSERT_EQ(sim->command("set 2 W45" + std::to_string(i) + " " + std::to_string(kFanValue(i))), "ok");
        }
        // A pump commissioned before: its read block selects FD00, FD01, FE03, FE05, FC91 (the
        // selectors take effect after a reset; the set-up tests start from the factory).
        sim->commission_read_block(1, {2, 1, 3, 4, 5});
        config.device = sim->link();
        config.response_timeout = 50ms;
        auto pump = drive("pump", 1, atv21);
        pump.polls.push_back(poll(*atv21, {"FD00", "FD01", "FE03", "FE05", "FC91"}, 100ms, true));
        pump.keep_alive = 1s;
        config.drives.push_back(pump);
        auto fan = drive("fan", 2, atv58);
        fan.polls.push_back(
            poll(*atv58, {"W450", "W451", "W452", "W453", "W454", "W455", "W456", "W457", "W458", "W459"}, 200ms));
        config.drives.push_back(fan);
    }
    void start() {
        loop = std::make_unique<bus::BusLoop>(config, recorder.callbacks());
        ASSERT_TRUE(loop->start().has_value());
    }
    void TearDown() override {
        if (loop) {
            loop->stop();
        }
    }
    // Waits until `n` more snapshots of `drive` have arrived.
    bool more_snapshots(const std::string& drive, std::size_t n, std::chrono::milliseconds timeout = 10s) {
        const std::size_t target = recorder.count(drive) + n;
        return wait_until([&] { return recorder.count(drive) >= target; }, timeout);
    }
    // On the simulator's side, no request started less than t3.5 after its last character,
    // except after a reply the master saw broken: a pty can hold a byte back in a kernel worker
    // past t3.5, and the master can only go by what it has received.
    void expect_no_short_silence() {
        const std::string s = sim->command("silences");
        ASSERT_EQ(s.find("count=0 "), std::string::npos) << s;
        const auto at = s.find(" short=");
        ASSERT_NE(at, std::string::npos) << s;
        const auto shorts = std::stoull(s.substr(at + 7));
        const auto& c = loop->status().counters;
        EXPECT_LE(shorts, c.crc_errors + c.gap_errors + c.noise + c.timeouts + c.malformed) << s;
    }
};

TEST_F(BusLoopTest, PollsBothDrivesWithTheSimulatorsValues) {
    ASSERT_EQ(sim->command("set 1 FA01 4500"), "ok");
    start();
    ASSERT_TRUE(more_snapshots("fan", 3));
    ASSERT_TRUE(more_snapshots("pump", 3));
    // On a loaded machine a pty can hold a byte back long enough to spoil a reply (it is then
    // retried, and its values marked invalid meanwhile): wait for a cycle that went through.
    ASSERT_TRUE(wait_until(
        [&] {
            const auto f = recorder.latest("fan");
            return f && f->registers.contains(459) && f->registers.at(459).valid;
        },
        10s));
    const auto fan = recorder.latest("fan");
    ASSERT_TRUE(fan);
    EXPECT_EQ(fan->health, Health::Online);
    for (std::uint16_t i = 0; i < 10; ++i) {
        EXPECT_TRUE(fan->registers.at(static_cast<std::uint16_t>(450 + i)).valid);
        EXPECT_EQ(fan->registers.at(static_cast<std::uint16_t>(450 + i)).value, kFanValue(i));
    }
    const auto pump = recorder.latest("pump");
    ASSERT_TRUE(pump);
    EXPECT_TRUE(pump->registers.at(0xFD01).valid);
    // The indirect block is set up on the drive: F875 selects FD00 (2).
    EXPECT_EQ(sim->command("get 1 F875"), "ok 2");
    EXPECT_EQ(recorder.wrong_values(), 0U);
    EXPECT_TRUE(loop->status().up);
    expect_no_short_silence();
}

// With send_spin the timer wakes the thread early and it spins to the send time: no request
// may start before the line is free, and the values still come through.
TEST_F(BusLoopTest, SpinningToTheSendTimeKeepsEverySilence) {
    std::mutex mutex;
    std::vector<std::pair<rtu::Instant, rtu::Instant>> writes;  // due, write() called
    bus::LoopOptions options;
    options.send_spin = 300us;
    options.on_written = [&](const bus::WriteTrace& w) {
        const std::lock_guard lock(mutex);
        writes.emplace_back(w.due, w.writing);
        EXPECT_LE(w.writing, w.written);
        EXPECT_GE(w.attempt, 1U);
    };
    loop = std::make_unique<bus::BusLoop>(config, recorder.callbacks(), options);
    ASSERT_TRUE(loop->start().has_value());
    ASSERT_TRUE(more_snapshots("fan", 5));
    ASSERT_TRUE(more_snapshots("pump", 5));
    loop->stop();
    const std::lock_guard lock(mutex);
    ASSERT_GE(writes.size(), 10U);
    for (const auto& [due, writing] : writes) {
        EXPECT_GE(writing, due) << "a request started before it was due or the t3.5 silence was over";
    }
    EXPECT_EQ(recorder.wrong_values(), 0U);
    expect_no_short_silence();
}

TEST_F(BusLoopTest, EveryFaultIsSurvivedAndCounted) {
    start();
    ASSERT_TRUE(more_snapshots("fan", 2));
    const std::vector<std::pair<std::string, std::function<bool(const master::BusCounters&)>>> faults{
        {"crc=0.5", [](const auto& c) { return c.crc_errors > 0; }},
        {"drop=0.5", [](const auto& c) { return c.timeouts > 0; }},
        // A silence inside a reply: held to the reply's wire bound and accepted when its
        // silences add up to no more than t3.5 (a delivery the kernel held back looks the
        // same), a gap error when the pty stretched it further.
        {"gap=6:2.5", [](const auto& c) { return c.gap_errors + c.held_replies > 0; }},
        {"noise=3:2", [](const auto& c) { return c.noise + c.gap_errors > 0; }},
        {"late=80ms", [](const auto& c) { return c.timeouts > 0; }},
        {"exception=6", [](const auto& c) { return c.exceptions[6] > 0; }},
    };
    for (const auto& [fault, seen] : faults) {
        ASSERT_EQ(sim->command("fault 2 " + fault).rfind("ok", 0), 0U) << fault;
        const auto before = loop->status().counters;
        EXPECT_TRUE(wait_until(
            [&] {
                auto now = loop->status().counters;
                // Compare what grew since the fault was set.
                master::BusCounters delta = now;
                delta.crc_errors -= before.crc_errors;
                delta.timeouts -= before.timeouts;
                delta.gap_errors -= before.gap_errors;
                delta.held_replies -= before.held_replies;
                delta.noise -= before.noise;
                delta.exceptions[6] -= before.exceptions[6];
                return seen(delta);
            },
            10s))
            << fault << " was not seen by the master";
        ASSERT_EQ(sim->command("clear").rfind("ok", 0), 0U);
        ASSERT_TRUE(more_snapshots("fan", 2)) << "polling did not recover after " << fault;
    }
    EXPECT_EQ(recorder.wrong_values(), 0U) << "a value from a faulty reply was accepted";
    expect_no_short_silence();
}

TEST_F(BusLoopTest, EchoOnA2WireLine) {
    config.echo = config::EchoMode::Auto;
    ASSERT_EQ(sim->command("fault * echo=1").rfind("ok", 0), 0U);
    start();
    ASSERT_TRUE(more_snapshots("fan", 3));
    ASSERT_TRUE(wait_until(
        [&] {
            const auto f = recorder.latest("fan");
            return f && f->registers.contains(455) && f->registers.at(455).valid;
        },
        10s));
    EXPECT_EQ(recorder.latest("fan")->registers.at(455).value, kFanValue(5));
    EXPECT_EQ(recorder.wrong_values(), 0U);
    // The echo matched every request, except where the simulator itself stalled in the middle
    // of a reply on a loaded machine and the master's next request met its late bytes: a real
    // collision, which the master must count as one.
    const std::string s = sim->command("silences");
    const auto at = s.find(" after_slip=");
    ASSERT_NE(at, std::string::npos) << s;
    const auto& c = loop->status().counters;
    EXPECT_LE(c.echo_mismatches, std::stoull(s.substr(at + 12)) + c.crc_errors + c.gap_errors + c.noise) << s;
}

TEST_F(BusLoopTest, AbsentDriveDoesNotDelayTheOther) {
    start();
    ASSERT_TRUE(more_snapshots("fan", 2));
    ASSERT_EQ(sim->command("fault 1 drop=1").rfind("ok", 0), 0U);
    ASSERT_TRUE(
        wait_until([&] { return recorder.latest("pump") && recorder.latest("pump")->health == Health::Absent; }, 10s));
    // The fan keeps its 200 ms period: 10 cycles take about 2 s; allow for a slow machine.
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(more_snapshots("fan", 10));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 6s);
    ASSERT_EQ(sim->command("clear").rfind("ok", 0), 0U);
    EXPECT_TRUE(wait_until([&] { return recorder.latest("pump")->health == Health::Online; }, 15s));
}

TEST_F(BusLoopTest, DeviceVanishesAndComesBack) {
    start();
    ASSERT_TRUE(more_snapshots("fan", 2));
    const auto dir = sim->link().parent_path();
    ASSERT_EQ(sim->stop(), 0);
    EXPECT_TRUE(wait_until([&] { return !loop->status().up; }, 10s)) << "the bus did not notice the device going";
    // The device comes back at the same path (a new pty behind the same link).
    auto again =
        std::make_unique<SimProcess>(std::vector<std::string>{"--drive", "1:atv21", "--drive", "2:atv58"}, dir);
    for (std::uint16_t i = 0; i < 10; ++i) {
        ASSERT_EQ(again->command("set 2 W45" + std::to_string(i) + " " + std::to_string(kFanValue(i))), "ok");
    }
    EXPECT_TRUE(wait_until([&] { return loop->status().up; }, 15s)) << "the bus did not reopen";
    EXPECT_TRUE(more_snapshots("fan", 3));
    EXPECT_EQ(recorder.latest("fan")->health, Health::Online);
    EXPECT_GE(loop->status().counters.line_down, 1U);
    loop->stop();
    sim = std::move(again);
}

// An unplugged USB adapter hangs its tty up: read() returns 0 and poll() says POLLHUP for
// ever after, unlike the closed pty master above (EIO). The bus goes down at once, its thread
// does not spin on the descriptor that stays ready, and the line comes back with the device.
// The poll period is an hour, so no write can be what notices the loss.
TEST_F(BusLoopTest, HangUpIsLineDownWithoutSpinning) {
    namespace fs = std::filesystem;
    using std::chrono::steady_clock;
    config.drives.clear();
    auto fan = drive("fan", 2, atv58);
    fan.polls.push_back(poll(*atv58, {"W450"}, std::chrono::hours(1)));
    config.drives.push_back(fan);
    start();
    ASSERT_TRUE(wait_until([&] { return recorder.count("fan") >= 1; }, 10s));

    // The device goes away: its path with it (until renamed back), and its tty hung up, as the
    // USB serial driver does on unplugging (vhangup() needs CAP_SYS_ADMIN).
    const fs::path link = sim->link();
    const fs::path away = link.string() + ".away";
    const fs::path tty = fs::read_symlink(link);
    fs::rename(link, away);
    {
        const sys::UniqueFd holder(::open(tty.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC));
        ASSERT_TRUE(holder.valid()) << tty << ": " << std::strerror(errno);
        if (::ioctl(holder.get(), TIOCVHANGUP) != 0) {
            fs::rename(away, link);
            GTEST_SKIP() << "TIOCVHANGUP needs CAP_SYS_ADMIN: " << std::strerror(errno);
        }
    }
    ASSERT_TRUE(wait_until([&] { return !loop->up(); }, 10s)) << "the bus did not notice the hang-up";
    EXPECT_EQ(loop->status().counters.line_down, 1U);

    // Down, the loop wakes for its liveness tick (twice a second) and its reopen attempts: a
    // few times a second, where a loop reading a hung-up tty goes round thousands of times.
    const std::uint64_t h0 = loop->heartbeat();
    const auto t0 = steady_clock::now();
    ASSERT_TRUE(wait_until([&] { return steady_clock::now() - t0 >= 1s && loop->heartbeat() - h0 >= 2; }, 10s))
        << "the loop stopped going round";
    const double seconds = std::chrono::duration<double>(steady_clock::now() - t0).count();
    const std::uint64_t rounds = loop->heartbeat() - h0;
    EXPECT_LE(static_cast<double>(rounds), 20.0 + 20.0 * seconds) << rounds << " rounds in " << seconds << " s";
    EXPECT_FALSE(loop->up()) << "up while the device was away";

    const std::size_t before = recorder.count("fan");
    fs::rename(away, link);
    ASSERT_TRUE(wait_until([&] { return loop->up(); }, 15s)) << "the bus did not reopen";
    // Reopened, the line polls at once: the value comes through the same pty again.
    EXPECT_TRUE(wait_until(
        [&] {
            const auto f = recorder.latest("fan");
            return recorder.count("fan") > before && f && f->registers.contains(450) && f->registers.at(450).valid;
        },
        10s));
    EXPECT_EQ(recorder.latest("fan")->registers.at(450).value, kFanValue(0));
    EXPECT_EQ(loop->status().counters.line_down, 1U);
    EXPECT_EQ(recorder.wrong_values(), 0U);
}

// A port that takes no output (stopped, as by an XOFF, or its buffer full): the bus thread
// waits for room in its event loop, not in a wait of its own, so it still reads what arrives
// meanwhile; the request goes out whole once there is room.
TEST(BusLoopOutput, AFullOutputBufferIsWaitedForInTheLoop) {
    int master_fd = -1;
    int slave_fd = -1;
    ASSERT_EQ(::openpty(&master_fd, &slave_fd, nullptr, nullptr, nullptr), 0) << std::strerror(errno);
    const std::string slave_path = ::ttyname(slave_fd);
    config::BusConfig config = bus<config::BusConfig>();
    config.device = slave_path;
    config.drives.push_back(drive("pump", 1, load("atv21")));  // nothing polled: only what is asked
    bus::LoopOptions options;
    options.output_stall = 60s;
    bus::BusLoop loop(config, {}, options);
    ASSERT_TRUE(loop.start().has_value());
    ASSERT_TRUE(wait_until([&] { return loop.up(); }, 10s));
    // Stop the tty's output (as an XOFF would): the port takes nothing until it is restarted.
    ASSERT_EQ(::tcflow(slave_fd, TCOOFF), 0) << std::strerror(errno);
    ASSERT_TRUE(loop.submit({1, 7, {1, rtu::ReadHoldingRegisters{0xFD00, 1}}}).has_value());
    // While the request waits for room, three stray characters come in: the bus thread reads
    // them (a frame too short to be anything) with the line still up and nothing written.
    const std::array<std::uint8_t, 3> stray{0x11, 0x22, 0x33};
    ASSERT_EQ(::write(master_fd, stray.data(), stray.size()), 3);
    ASSERT_TRUE(wait_until([&] { return loop.status().counters.noise >= 1; }, 10s));
    EXPECT_EQ(loop.status().counters.line_down, 0U);
    EXPECT_EQ(loop.status().counters.transmissions, 0U) << "the request is not written yet";
    EXPECT_TRUE(loop.up());
    // Room again: the request goes out whole.
    ASSERT_EQ(::tcflow(slave_fd, TCOON), 0) << std::strerror(errno);
    const auto request = rtu::encode_request({1, rtu::ReadHoldingRegisters{0xFD00, 1}}).value();
    std::vector<std::uint8_t> seen;
    const bool arrived = wait_until(
        [&] {
            std::array<std::uint8_t, 256> buffer{};
            pollfd p{master_fd, POLLIN, 0};
            while (::poll(&p, 1, 0) > 0) {
                const ssize_t n = ::read(master_fd, buffer.data(), buffer.size());
                if (n <= 0) {
                    break;
                }
                seen.insert(seen.end(), buffer.begin(), buffer.begin() + n);
            }
            return seen.size() >= request.size();
        },
        10s);
    ASSERT_TRUE(arrived) << seen.size() << " of " << request.size() << " bytes";
    EXPECT_TRUE(std::equal(request.bytes().begin(), request.bytes().end(), seen.begin()));
    EXPECT_TRUE(wait_until([&] { return loop.status().counters.transmissions == 1; }, 10s));
    EXPECT_EQ(loop.status().counters.line_down, 0U);
    loop.stop();
    ::close(slave_fd);
    ::close(master_fd);
}

}  // namespace
}  // namespace drivebus::test
