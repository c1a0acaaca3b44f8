// SPDX-License-Identifier: Apache-2.0
// drivebusd's reload (SIGHUP) with clients connected, each its own process: a changed poll
// period is applied by restarting the bus alone, and both clients keep their subscriptions and
// the holder its control lease; a broken file, or a change that needs a restart, is refused
// with one line and the running configuration goes on.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "client_process.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

struct Seen {
    std::uint64_t sequence = 0;
    std::int64_t fd00_read_ns = 0;
};

// The watcher's "snapshot SEQUENCE FD00 READ_NS" lines from `from` (an offset into its output).
std::vector<Seen> snapshots(const std::string& output, std::size_t from) {
    std::vector<Seen> out;
    for (const auto& line : lines_with(output.substr(std::min(from, output.size())), "snapshot ")) {
        std::istringstream in(line.substr(9));
        Seen s;
        unsigned value = 0;
        in >> s.sequence >> value >> s.fd00_read_ns;
        out.push_back(s);
    }
    return out;
}

void rewrite(const Stack& stack, const std::string& text) {
    std::ofstream(stack.config(), std::ios::trunc) << text;
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) {
        throw std::runtime_error("the stack's configuration has no " + from);
    }
    return text.replace(at, from.size(), to);
}

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) {
        ++n;
    }
    return n;
}

// Sends SIGHUP and waits for drivebusd's word on it (its `times`-th line with `says`).
void reload(Stack& stack, const std::string& says, std::size_t times) {
    ASSERT_EQ(::kill(stack.daemon_pid(), SIGHUP), 0);
    ASSERT_TRUE(wait_until([&] { return count(stack.daemon_output(), says) >= times; }, 20s))
        << "drivebusd never said " << says << ":\n"
        << stack.daemon_output();
}

TEST(Reload, AChangedPollPeriodIsAppliedWhileBothClientsStayAndTheLeaseHolds) {
    StackOptions options;
    options.drive_extra = "  lease = \"1s\"\n  fallback = \"stop\"\n";
    options.poll_period = "50ms";
    Stack stack(options);
    Client holder({stack.bus(), "command", "30"});
    Client watcher({stack.bus(), "watch"});
    ASSERT_TRUE(holder.printed("holding", 10s)) << holder.output();
    ASSERT_TRUE(watcher.printed("snapshot ", 10s)) << watcher.output();

    // The same file again: nothing is restarted.
    reload(stack, "reload: no change", 1);

    // The pump's fast poll group: 50 ms to 2 s.
    rewrite(stack, replaced(stack.config_text(), "period = \"50ms\"", "period = \"2s\""));
    const auto before = watcher.output().size();
    const auto last_before = snapshots(watcher.output(), 0).back().sequence;
    reload(stack, "reload: restarted (settings changed) " + stack.bus(), 1);
    EXPECT_NE(stack.daemon_output().find("the lease of test_client_command"), std::string::npos)
        << stack.daemon_output();

    // The watcher's subscription goes on, with sequences after those it saw: it waits for a new
    // one, never for one it already has. FD00 is now read every 2 s: over any span of reads, at
    // most one read per period and one at each end (at 50 ms, a 4 s span would hold some 80).
    std::vector<Seen> after;
    std::set<std::int64_t> reads;
    ASSERT_TRUE(wait_until(
        [&] {
            after = snapshots(watcher.output(), before);
            reads.clear();
            for (const auto& s : after) {
                if (s.fd00_read_ns != 0) {
                    reads.insert(s.fd00_read_ns);
                }
            }
            return reads.size() >= 2 && *reads.rbegin() - *reads.begin() >= std::chrono::nanoseconds(4s).count();
        },
        40s))
        << watcher.output().substr(before) << "\n"
        << stack.daemon_output();
    EXPECT_GT(after.front().sequence, last_before);
    EXPECT_LE(reads.size(), 4U) << watcher.output().substr(before);

    // The lease held all along: the holder's drive still runs to its reference, no lease ran
    // out, and another client's write is still refused.
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") == 3000; }, 20s))
        << "FD00 = " << stack.sim_register(1, "FD00") << ", FA00 = " << stack.sim_register(1, "FA00") << "\n"
        << stack.daemon_output() << "\nholder:\n"
        << holder.output();
    EXPECT_EQ(stack.sim_register(1, "FA00"), 0xC400);
    EXPECT_EQ(stack.daemon_output().find("ran out"), std::string::npos) << stack.daemon_output();
    Client other({stack.bus(), "writes", "FA01", "1000"});
    EXPECT_EQ(other.wait(10s), 1) << other.output();
    EXPECT_NE(other.output().find("not permitted"), std::string::npos) << other.output();
    // The published lease: held (the client waits 5 s for an expiry that does not come, and
    // says so with status 1), its holder kept.
    Client lease({stack.bus(), "lease"});
    ASSERT_EQ(lease.wait(15s), 1) << lease.output();
    EXPECT_NE(lease.output().find("lease held holder kept"), std::string::npos) << lease.output();
    // Both clients are still there.
    EXPECT_EQ(holder.wait(0ms), -1) << holder.output();
    EXPECT_EQ(watcher.wait(0ms), -1) << watcher.output();
}

TEST(Reload, ABrokenFileOrAChangeThatNeedsARestartIsRefusedAndTheOldConfigurationRuns) {
    Stack stack;
    Client watcher({stack.bus(), "watch"});
    ASSERT_TRUE(watcher.printed("snapshot ", 10s)) << watcher.output();
    const auto good = stack.config_text();

    rewrite(stack, good + "[[bus]\n");
    reload(stack, "reload refused, the running configuration stays: " + stack.config().string() + ": line ", 1);
    rewrite(stack, replaced(good, "roudi = \"embedded\"", "roudi = \"embedded\"\nmax_clients = 5"));
    reload(stack, "reload refused, the running configuration stays: [ipc] changed", 1);
    // A second bus needs shared memory set up at start for it.
    const auto fragments = stack.dir() / "drivebusd.d";
    std::filesystem::create_directories(fragments);
    std::ofstream(fragments / "line2.toml") << "[[bus]]\nname = \"" << stack.bus()
                                            << "x\"\ndevice = \"/dev/null-drivebus\"\n  [[bus.drive]]\n"
                                               "  name = \"mixer\"\n  address = 3\n  profile = \"atv21\"\n";
    rewrite(stack, good);
    reload(stack, "restart drivebusd to apply it", 1);
    std::filesystem::remove_all(fragments);

    // Each refusal is one line, and nothing was restarted: the bus polls on.
    const auto out = stack.daemon_output();
    EXPECT_EQ(out.find("reload: restarted"), std::string::npos) << out;
    EXPECT_EQ(out.find("reload: kept"), std::string::npos) << out;
    const auto seen = watcher.output().size();
    ASSERT_TRUE(wait_until([&] { return snapshots(watcher.output(), seen).size() >= 10; }, 20s))
        << watcher.output().substr(seen);
    EXPECT_EQ(watcher.wait(0ms), -1) << watcher.output();
    // And the next good file is taken.
    rewrite(stack, good);
    reload(stack, "reload: no change", 1);
}

}  // namespace
}  // namespace drivebus::test
