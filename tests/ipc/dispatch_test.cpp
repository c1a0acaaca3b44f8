// SPDX-License-Identifier: Apache-2.0
// libdrivebus on the application's own event loop (Delivery::Dispatch), each client its own
// process against drivebusd and drivebus-sim: the example poll loop reads, writes, renews its
// lease and follows snapshots with no thread of the library's; the blocking calls run by
// dispatch() get the same answers as on the library's threads; a request to a line gone quiet
// ends by its time-out; and a client whose drivebusd goes away is not left waiting.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "client_process.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// The value after `key` in the example's summary line ("snapshots 41 out-of-order 0 ...").
int summary_value(const std::string& output, const std::string& key) {
    const auto line = output.find("snapshots ");
    const auto at = output.find(" " + key + " ", line);
    if (line == std::string::npos || (key != "snapshots" && at == std::string::npos)) {
        return -1;
    }
    const auto from = key == "snapshots" ? line + key.size() + 1 : at + key.size() + 2;
    return std::atoi(output.c_str() + from);
}

// A test_client run with the Bus on dispatch().
class DispatchClient : public Client {
public:
    explicit DispatchClient(const std::vector<std::string>& args) : Client(with_env(args)) {
        ::unsetenv("DRIVEBUS_TEST_DELIVERY");
    }

private:
    static const std::vector<std::string>& with_env(const std::vector<std::string>& args) {
        ::setenv("DRIVEBUS_TEST_DELIVERY", "dispatch", 1);  // the child inherits it at fork
        return args;
    }
};

TEST(Dispatch, AnApplicationOnItsOwnPollLoopReadsWritesAndFollowsSnapshots) {
    Stack stack;
    Client app({"--bus", stack.bus(), "--seconds", "2"}, POLL_LOOP_PATH);
    ASSERT_EQ(app.wait(30s), 0) << app.output() << stack.daemon_output();
    const auto out = app.output();
    EXPECT_NE(out.find("write FA01 3000 ok"), std::string::npos) << out;
    EXPECT_NE(out.find("release ok"), std::string::npos) << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000) << "the write did not reach the drive\n" << out;
    // Two seconds of 50 ms polls (about 40 snapshots), and a read and a renewal every 100 ms
    // of the loop's own timer (about 20 each): a quarter of that on a loaded machine.
    EXPECT_GE(summary_value(out, "snapshots"), 10) << out;
    EXPECT_EQ(summary_value(out, "out-of-order"), 0) << out;
    EXPECT_GE(summary_value(out, "reads"), 5) << out;
    EXPECT_GE(summary_value(out, "renewals"), 5) << out;
    EXPECT_EQ(summary_value(out, "failures"), 0) << out;
    // Its threads: its own and the iceoryx runtime's keep-alive; none of libdrivebus's (a
    // listener and a sender with Delivery::Thread).
    EXPECT_NE(out.find("threads 2 poll_loop,KeepAlive\n"), std::string::npos) << out;
}

// How many sockets of this network namespace carry `path`: a listening socket, and each
// connection it accepted.
std::size_t sockets_at(const std::string& path) {
    std::ifstream table("/proc/net/unix");
    std::size_t count = 0;
    for (std::string line; std::getline(table, line);) {
        count += line.ends_with(" " + path) ? 1U : 0U;
    }
    return count;
}

TEST(Dispatch, DrivebusdWakesEachApplicationOnItsSocketAndLetsTheGoneOnesGo) {
    Stack stack;
    const std::string path = "/tmp/drivebus-" + stack.bus() + ".wake";
    ASSERT_TRUE(wait_until([&] { return sockets_at(path) == 1; }, 10s)) << "no socket listens at " << path;
    {
        Client threads({stack.bus(), "snapshots", "1000000"});  // Delivery::Thread: not connected
        DispatchClient follower({stack.bus(), "snapshots", "1000000"});
        ASSERT_TRUE(follower.printed("snapshot ", 20s)) << follower.output();
        ASSERT_TRUE(threads.printed("snapshot ", 20s)) << threads.output();
        EXPECT_TRUE(wait_until([&] { return sockets_at(path) == 2; }, 10s)) << sockets_at(path);
        follower.kill9();
    }
    // Its next wake-up finds the connection closed.
    EXPECT_TRUE(wait_until([&] { return sockets_at(path) == 1; }, 10s)) << sockets_at(path);
    EXPECT_EQ(stack.stop_daemon(), 0);
    EXPECT_FALSE(std::filesystem::exists(path)) << "drivebusd left its socket behind";
}

TEST(Dispatch, BlockingCallsOnDispatchAreAnsweredAsOnTheLibrarysThreads) {
    Stack stack;
    DispatchClient reader({stack.bus(), "read", "FD01", "20"});
    DispatchClient writer({stack.bus(), "writes", "FA51", "11", "22", "33"});
    DispatchClient follower({stack.bus(), "snapshots", "10"});
    for (auto* c : {&reader, &writer, &follower}) {
        ASSERT_EQ(c->wait(30s), 0) << c->output() << stack.daemon_output();
    }
    EXPECT_EQ(lines_with(reader.output(), "value ").size(), 20U) << reader.output();
    EXPECT_EQ(lines_with(writer.output(), "ok ").size(), 3U) << writer.output();
    EXPECT_EQ(stack.sim_register(1, "FA51"), 33);
    const auto seqs = lines_with(follower.output(), "snapshot ");
    ASSERT_EQ(seqs.size(), 10U) << follower.output();
    std::uint64_t last = 0;
    for (const auto& line : seqs) {
        const auto seq = std::stoull(line.substr(9));
        EXPECT_GT(seq, last) << follower.output();
        last = seq;
    }
}

TEST(Dispatch, ARequestToALineGoneQuietEndsByItsTimeOut) {
    Stack stack;
    ASSERT_EQ(stack.sim().command("mute").rfind("ok", 0), 0U) << stack.sim().output();
    DispatchClient reader({stack.bus(), "read", "FD01", "1"});
    // The drive's retries run out, or the library's 2 s time-out with its withdrawal: an error
    // either way, never a hang and never a value.
    ASSERT_EQ(reader.wait(20s), 1) << reader.output() << stack.daemon_output();
    EXPECT_TRUE(lines_with(reader.output(), "value ").empty()) << reader.output();
}

TEST(Dispatch, AClientWhoseDaemonIsGoneIsNotLeftWaiting) {
    Stack stack;
    DispatchClient follower({stack.bus(), "snapshots", "1000000"});
    ASSERT_TRUE(follower.printed("snapshot ", 20s)) << follower.output();
    stack.kill_daemon();
    // The library's wait_snapshot() loop waits on until the library says drivebusd is gone; or
    // iceoryx 2.0 itself ends the client (SIGABRT from its keep-alive once RouDi's socket
    // refuses it: docs/ipc.md). It never hangs, and what the library keeps of a RouDi gone is
    // no leak (the sanitizer build checks leaks at exit).
    const int status = follower.wait(20s);
    ASSERT_TRUE(status == 1 || status == 128 + SIGABRT) << status << "\n" << follower.output();
    if (status == 1) {
        EXPECT_NE(follower.output().find("gone silent"), std::string::npos) << follower.output();
    }
}

}  // namespace
}  // namespace drivebus::test
