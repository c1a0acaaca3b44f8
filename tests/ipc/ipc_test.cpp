// SPDX-License-Identifier: Apache-2.0
// drivebusd + drivebus-sim + clients, each its own process: snapshots reach every subscriber,
// requests from several clients are all answered and applied in order, a client killed in the
// middle of its requests disturbs nobody, and a control lease that runs out stops the drive.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "client_process.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

TEST(Ipc, TwoClientsBothSeeEverySnapshotInOrder) {
    Stack stack;
    Client a({stack.bus(), "snapshots", "10"});
    Client b({stack.bus(), "snapshots", "10"});
    ASSERT_EQ(a.wait(20s), 0) << a.output();
    ASSERT_EQ(b.wait(20s), 0) << b.output();
    for (auto* c : {&a, &b}) {
        const auto lines = lines_with(c->output(), "snapshot ");
        ASSERT_EQ(lines.size(), 10U) << c->output();
        std::uint64_t last = 0;
        for (const auto& line : lines) {
            const auto seq = std::stoull(line.substr(9));
            EXPECT_GT(seq, last) << c->output();
            last = seq;
        }
    }
}

TEST(Ipc, TwoClientsReadAtOnce) {
    Stack stack;
    Client a({stack.bus(), "read", "FD01", "20"});
    Client b({stack.bus(), "read", "0xFE03", "20"});
    ASSERT_EQ(a.wait(30s), 0) << a.output();
    ASSERT_EQ(b.wait(30s), 0) << b.output();
    EXPECT_EQ(lines_with(a.output(), "value ").size(), 20U);
    EXPECT_EQ(lines_with(b.output(), "value ").size(), 20U);
}

TEST(Ipc, WritesFromTwoClientsAreAllAppliedEachInItsOrder) {
    Stack stack;
    // FA51 (analog output command) takes no control lease: both may write it.
    std::vector<std::string> first = {stack.bus(), "writes", "FA51"};
    std::vector<std::string> second = {stack.bus(), "writes", "FA51"};
    for (int i = 0; i < 15; ++i) {
        first.push_back(std::to_string(100 + i));
        second.push_back(std::to_string(500 + i));
    }
    Client a(first);
    Client b(second);
    ASSERT_EQ(a.wait(30s), 0) << a.output();
    ASSERT_EQ(b.wait(30s), 0) << b.output();
    const auto log = stack.sim().command("writes 1");
    std::vector<int> from_a;
    std::vector<int> from_b;
    std::istringstream in(log.substr(3));
    for (std::string item; in >> item;) {
        if (item.rfind("0xFA51=", 0) == 0) {
            const int v = std::stoi(item.substr(7));
            auto& seq = v < 500 ? from_a : from_b;
            // A write whose reply was spoiled is sent again: Modbus RTU has no transaction id,
            // so the drive may apply it twice, back to back. That is not a reordering.
            if (seq.empty() || seq.back() != v) {
                seq.push_back(v);
            }
        }
    }
    std::vector<int> want_a;
    std::vector<int> want_b;
    for (int i = 0; i < 15; ++i) {
        want_a.push_back(100 + i);
        want_b.push_back(500 + i);
    }
    EXPECT_EQ(from_a, want_a) << log;
    EXPECT_EQ(from_b, want_b) << log;
}

// The reader keeps getting its values while clients reading in a tight loop are SIGKILLed beside
// it. A client killed inside iceoryx's send() leaves iceoryx 2.0's (non-robust) port locks held:
// this reader's own send() and RouDi's clean-up of the dead client then waited on them for good
// (the reader hung after 4-19 of its 60 values). drivebusd frees such locks (ipc/held_locks.hpp)
// and libdrivebus never waits on iceoryx past a request's time-out (client/lib/sender.hpp). On a
// hang, the failure message says where each thread of the hung client waits.
TEST(Ipc, AClientKilledMidRequestDisturbsNeitherTheDaemonNorTheOthers) {
    Stack stack;
    Client reader({stack.bus(), "read", "FD00", "60"});
    for (int round = 0; round < 3; ++round) {
        Client flood({stack.bus(), "flood", "FD01"});
        ASSERT_TRUE(flood.printed("ready", 10s)) << flood.output() << "\n[flood: " << flood.threads() << "]\n"
                                                 << stack.daemon_output();
        flood.kill9();  // almost surely with a request queued or on the wire
    }
    ASSERT_EQ(reader.wait(30s), 0) << reader.output() << "\n" << stack.daemon_output();
    EXPECT_EQ(lines_with(reader.output(), "value ").size(), 60U);
    // The daemon still serves a newcomer.
    Client after({stack.bus(), "read", "FD00", "3"});
    ASSERT_EQ(after.wait(10s), 0) << after.output();
    EXPECT_EQ(stack.daemon_output().find("fatal"), std::string::npos) << stack.daemon_output();
}

// The same, made likely: clients that spend their time inside iceoryx's send() (8 requests in
// flight, the next sent as each answer comes) are SIGKILLed two at a time, so that some die
// holding the locks of their port and of the bus's request queue: ten rounds at least, and more
// until drivebusd says it freed such a lock (40 at most). Every newcomer still gets its port
// (RouDi's clean-up of the dead did not stall it), the reader still gets all its values, a
// client after them all is served, and the reaper did free what the dead left held.
TEST(Ipc, ClientsKilledInsideSendStallNeitherRouDiNorTheOthers) {
    Stack stack;
    Client reader({stack.bus(), "read", "FD00", "100"});
    const auto freed = [&] { return stack.daemon_output().find("lock(s) that a killed client had left held"); };
    for (int round = 0; round < 10 || (round < 40 && freed() == std::string::npos); ++round) {
        std::vector<std::unique_ptr<Client>> spammers;
        for (int i = 0; i < 2; ++i) {
            spammers.push_back(
                std::make_unique<Client>(std::vector<std::string>{stack.bus(), "spam"}, RAW_REQUEST_PATH));
        }
        for (auto& s : spammers) {
            ASSERT_TRUE(s->printed("spamming", 10s))
                << "round " << round << ": " << s->output() << "\n[reader: " << reader.threads() << "]\n"
                << stack.daemon_output();
        }
        for (auto& s : spammers) {
            s->kill9();
        }
    }
    // A reader still running names its threads' wait channels; drivebusd's (RouDi's among
    // them) say what it waits on.
    ASSERT_EQ(reader.wait(60s), 0) << reader.output() << "\n[drivebusd: " << Client::threads_of(stack.daemon_pid())
                                   << "]\n"
                                   << stack.daemon_output();
    EXPECT_EQ(lines_with(reader.output(), "value ").size(), 100U);
    Client after({stack.bus(), "read", "FD00", "3"});
    ASSERT_EQ(after.wait(10s), 0) << after.output() << "\n" << stack.daemon_output();
    EXPECT_EQ(stack.daemon_output().find("fatal"), std::string::npos) << stack.daemon_output();
    EXPECT_NE(freed(), std::string::npos) << stack.daemon_output();
}

// Subscription::reset() returns only once its callback has: what the callback touches may go
// then. (drivebus-mqtt freed a drive's link while a snapshot callback was still writing into
// it; ThreadSanitizer saw it at the bridge's stop.)
TEST(Ipc, ASubscriptionResetWaitsForItsCallbackUnderWay) {
    Stack stack;
    Client c({stack.bus(), "unsubscribe"});
    ASSERT_EQ(c.wait(30s), 0) << c.output() << "\n" << stack.daemon_output();
    EXPECT_NE(c.output().find("reset waited for the callback"), std::string::npos) << c.output();
}

// Host pids `count` in a row that no process or thread has: a child PID namespace whose pids
// start there numbers its threads as no thread here is numbered, as a container's often are.
pid_t free_pid_window(int count) {
    long max = 32768;
    std::ifstream("/proc/sys/kernel/pid_max") >> max;
    for (long base = max - count - 2; base > 1000; base -= count) {
        bool free = true;
        for (long pid = base + 1; pid <= base + count && free; ++pid) {
            free = ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
        }
        if (free) {
            return static_cast<pid_t>(base);
        }
    }
    return 0;
}

// A client in a container: its own PID namespace (unshare --pid), the same /dev/shm and RouDi
// socket, sending in a loop (most of its time inside iceoryx's send()). Its thread ids mean
// nothing in drivebusd's namespace (here no thread has them), so drivebusd cannot judge who
// holds its locks, says so once, and frees none while it is connected. Before, a lock the
// client held at two looks 100 ms apart was taken from it (the thread id was "dead"), and the
// client or drivebusd ended on iceoryx's fatal error, or values went astray. A reader on the
// host is served beside it throughout. DRIVEBUS_CONTAINER_SECONDS (20 by default) sets how long
// the client sends.
TEST(Ipc, AClientInAnotherPidNamespaceNeverHasALockTakenFromIt) {
    if (::geteuid() != 0) {
        GTEST_SKIP() << "a PID namespace of the test's making needs root";
    }
    const char* unshare = "/usr/bin/unshare";
    if (::access(unshare, X_OK) != 0) {
        GTEST_SKIP() << "no /usr/bin/unshare (util-linux)";
    }
    const char* env = std::getenv("DRIVEBUS_CONTAINER_SECONDS");
    const int seconds = env != nullptr && std::atoi(env) > 0 ? std::atoi(env) : 20;
    const pid_t base = free_pid_window(64);
    ASSERT_GT(base, 0) << "no 64 free pids in a row";
    Stack stack;
    // In the namespace, sh is pid 1; the client, forked once the next pid is set, base + 1.
    const std::string script = "echo " + std::to_string(base) + " > /proc/sys/kernel/ns_last_pid || exit 9; " +
                               RAW_REQUEST_PATH + " " + stack.bus() + " spam " + std::to_string(seconds) + " & wait $!";
    Client contained({"--pid", "--fork", "--kill-child", "--mount-proc", "/bin/sh", "-c", script}, unshare);
    ASSERT_TRUE(contained.printed("spamming", 20s)) << contained.output() << "\n" << stack.daemon_output();
    const auto until = Clock::now() + std::chrono::seconds(seconds);
    int reads = 0;
    while (Clock::now() < until) {
        Client reader({stack.bus(), "read", "FD00", "5"});
        ASSERT_EQ(reader.wait(30s), 0) << reader.output() << "\n" << stack.daemon_output();
        ASSERT_EQ(lines_with(reader.output(), "value ").size(), 5U) << reader.output();
        ++reads;
    }
    ASSERT_EQ(contained.wait(60s), 0) << contained.output() << "\n" << stack.daemon_output();
    EXPECT_NE(contained.output().find("answered "), std::string::npos) << contained.output();
    const auto log = stack.daemon_output();
    const auto pid = std::to_string(base + 1);
    EXPECT_NE(log.find("are not freed while runtime 'raw_request-" + pid + "' (pid " + pid +
                       ") is connected: there is no process " + pid + " in drivebusd's PID namespace"),
              std::string::npos)
        << log;
    EXPECT_EQ(log.find("lock(s) that a killed client had left held"), std::string::npos) << log;
    EXPECT_EQ(log.find("fatal"), std::string::npos) << log;
    std::printf("%d readers of 5 values served beside the client in its PID namespace (%d s)\n", reads, seconds);
}

// Every request gets exactly one answer: 20 clients, each with 12 reads in flight at once
// (iceoryx directly, no library in between), three times over. The clients connect first and
// send together. What the queue limit (64) refuses is answered QueueFull at once; everything
// else with its value, or, on a machine so busy that the line's replies fail, with that error:
// one answer either way, never a rejection.
TEST(Ipc, AFloodOfClientsGetsOneAnswerPerRequest) {
    Stack stack;
    for (int round = 0; round < 3; ++round) {
        const auto go = stack.dir() / ("go-" + std::to_string(round));
        std::vector<std::unique_ptr<Client>> clients;
        for (int i = 0; i < 20; ++i) {
            clients.push_back(std::make_unique<Client>(
                std::vector<std::string>{stack.bus(), "flood", "12", go.string()}, RAW_REQUEST_PATH));
        }
        for (auto& c : clients) {
            ASSERT_TRUE(c->printed("connected", 30s)) << "round " << round << ": " << c->output();
        }
        std::ofstream(go.string()).put('\n');
        int ok = 0;
        int full = 0;
        for (auto& c : clients) {
            ASSERT_EQ(c->wait(30s), 0) << "round " << round << ": " << c->output();
            const auto& out = c->output();
            ASSERT_NE(out.find("answers 12 of 12 "), std::string::npos) << out;
            EXPECT_NE(out.find(" other 0 duplicates 0"), std::string::npos) << out;
            ok += std::stoi(out.substr(out.find(" ok ") + 4));
            full += std::stoi(out.substr(out.find(" full ") + 6));
        }
        // 240 at once against a limit of 64: both kinds of answer come.
        EXPECT_GT(ok, 0) << "round " << round;
        EXPECT_GT(full, 0) << "round " << round;
    }
    EXPECT_EQ(stack.daemon_output().find("defect"), std::string::npos) << stack.daemon_output();
}

// The drive's reference is 30 Hz (3000 in 0.01 Hz) and it runs; once the lease runs out,
// drivebusd's fallback (ramp stop) brings the simulated FD00 down to 0.
void expect_fallback_stops(Stack& stack, Client& holder) {
    ASSERT_TRUE(holder.printed("holding", 10s)) << holder.output();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") > 500; }, 10s)) << "the drive never ran";
    holder.kill9();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") == 0; }, 20s))
        << "FD00 = " << stack.sim_register(1, "FD00") << "\n"
        << stack.daemon_output();
    EXPECT_NE(stack.daemon_output().find("control lease of test_client_"), std::string::npos) << stack.daemon_output();
    EXPECT_NE(stack.daemon_output().find("fallback: stop"), std::string::npos) << stack.daemon_output();
}

TEST(Ipc, ALeaseThatRunsOutStopsTheDrive_KilledClient) {
    StackOptions options;
    options.drive_extra = "  lease = \"300ms\"\n  fallback = \"stop\"\n";
    Stack stack(options);
    Client holder({stack.bus(), "command", "30"});
    expect_fallback_stops(stack, holder);
}

// A hung application: its control thread blocks for good while the process, its other threads
// and iceoryx's stay alive. Nothing renews its lease any more, so the drive reaches its fallback
// (the ramp-stop word in FA00) within the lease time plus one poll period of the hung thread's
// last keep_alive(), and never before the lease time has passed. The upper bound is asserted
// with an allowance for a loaded machine: a library that renews on its own would never get
// there, whatever the allowance.
TEST(Ipc, ALeaseThatRunsOutStopsTheDrive_HungClient) {
    constexpr auto kLease = 300ms;
    constexpr auto kPoll = 50ms;
    constexpr auto kLoadAllowance = 10s;
    StackOptions options;
    options.drive_extra = "  lease = \"300ms\"\n";
    options.poll_period = "50ms";
    Stack stack(options);
    Client holder({stack.bus(), "hang", "30"});
    ASSERT_TRUE(holder.printed("holding", 10s)) << holder.output();
    ASSERT_TRUE(holder.printed("hung ", 20s)) << holder.output();
    const auto hung = lines_with(holder.output(), "hung ");
    ASSERT_EQ(hung.size(), 1U) << holder.output();
    const std::int64_t last_keep_alive_ns = std::stoll(hung[0].substr(5));
    const Clock::time_point last_keep_alive{std::chrono::nanoseconds(last_keep_alive_ns)};
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == 0xC000; },
                           std::chrono::duration_cast<std::chrono::milliseconds>(last_keep_alive + kLease + kPoll +
                                                                                 kLoadAllowance - Clock::now())))
        << "FA00 = " << stack.sim_register(1, "FA00") << "\n"
        << stack.daemon_output();
    // The process is alive all along: its main thread sees the expiry it caused.
    ASSERT_TRUE(holder.printed("expired ", 10s)) << holder.output();
    const auto expired = lines_with(holder.output(), "expired ");
    ASSERT_EQ(expired.size(), 1U) << holder.output();
    const std::int64_t expired_ns = std::stoll(expired[0].substr(8));
    EXPECT_GE(expired_ns - last_keep_alive_ns, std::chrono::nanoseconds(kLease).count()) << "ran out early";
    EXPECT_NE(expired[0].find("fallback_ok 1"), std::string::npos) << expired[0];
    // And the drive, told to stop, ramps down.
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") == 0; }, 20s))
        << "FD00 = " << stack.sim_register(1, "FD00");
    EXPECT_NE(stack.daemon_output().find("control lease of test_client_hang"), std::string::npos)
        << stack.daemon_output();
    EXPECT_NE(stack.daemon_output().find("fallback: stop"), std::string::npos) << stack.daemon_output();
}

// The fallback write has its own slot ahead of every client queue: with other clients
// flooding reads, a SIGKILLed holder's drive still gets its stop word (FA00 = 0xC000, the
// ATV21 profile's ramp stop), checked in the simulator, six times in a row. The lease
// snapshot keeps its last holder and the drive's register values.
TEST(Ipc, TheFallbackWriteIsNeverLostUnderAFlood) {
    StackOptions options;
    options.drive_extra = "  lease = \"300ms\"\n  fallback = \"stop\"\n";
    Stack stack(options);
    std::vector<std::unique_ptr<Client>> floods;
    for (int i = 0; i < 4; ++i) {
        floods.push_back(std::make_unique<Client>(std::vector<std::string>{stack.bus(), "flood", "FD01"}));
        ASSERT_TRUE(floods.back()->printed("ready", 10s)) << floods.back()->output();
    }
    for (int round = 0; round < 6; ++round) {
        Client holder({stack.bus(), "command", "30"});
        ASSERT_TRUE(holder.printed("holding", 10s)) << "round " << round << ": " << holder.output();
        ASSERT_EQ(stack.sim_register(1, "FA00"), 0xC400) << "round " << round;
        holder.kill9();
        ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == 0xC000; }, 10s))
            << "round " << round << ": FA00 = " << stack.sim_register(1, "FA00") << "\n"
            << stack.daemon_output();
    }
    Client lease({stack.bus(), "lease"});
    ASSERT_EQ(lease.wait(10s), 0) << lease.output();
    EXPECT_NE(lease.output().find("lease expired holder kept fallback_ok 1 registers 7"), std::string::npos)
        << lease.output();
}

TEST(Ipc, ALiveLeaseKeepsTheDriveRunningAndShutsOutOtherWriters) {
    StackOptions options;
    options.drive_extra = "  lease = \"300ms\"\n";
    Stack stack(options);
    Client holder({stack.bus(), "command", "30"});
    ASSERT_TRUE(holder.printed("holding", 10s)) << holder.output();
    const auto requests = stack.sim_requests();
    Client other({stack.bus(), "writes", "FA01", "1000"});
    EXPECT_EQ(other.wait(10s), 1) << other.output();
    EXPECT_NE(other.output().find("not permitted"), std::string::npos) << other.output();
    // Renewed all along: the drive ramps all the way to its reference, which takes many lease
    // lengths, and no lease runs out on the way.
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") == 3000; }, 20s))
        << "FD00 = " << stack.sim_register(1, "FD00");
    EXPECT_EQ(stack.daemon_output().find("ran out"), std::string::npos) << stack.daemon_output();
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000);
    // The refused write never reached the wire: only polls went out meanwhile, and none wrote FA01.
    EXPECT_GT(stack.sim_requests(), requests);
    EXPECT_EQ(stack.sim().command("writes 1").find("0xFA01=1000"), std::string::npos);
}

// Finding 7 of issue 14: the lease is a capability, not a name. A second client that poses as
// the holder (its client id, its published name and pid, a token of nothing or made of what it
// knows) can neither write the command nor renew nor release the lease; the holder keeps it,
// so when the holder then dies, the fallback follows.
TEST(Ipc, AClientPosingAsTheHolderCannotWriteUnderTheLeaseNorReleaseIt) {
    StackOptions options;
    options.drive_extra = "  lease = \"300ms\"\n  fallback = \"stop\"\n";
    Stack stack(options);
    Client holder({stack.bus(), "command", "30"});
    ASSERT_TRUE(holder.printed("holding", 10s)) << holder.output();
    ASSERT_TRUE(holder.printed("client ", 10s)) << holder.output();
    const auto id = lines_with(holder.output(), "client ");
    ASSERT_EQ(id.size(), 1U) << holder.output();
    ASSERT_EQ(stack.sim_register(1, "FA00"), 0xC400);

    Client impostor({stack.bus(), "impostor", id[0].substr(7)});
    EXPECT_EQ(impostor.wait(30s), 0) << impostor.output();
    EXPECT_EQ(lines_with(impostor.output(), "write not permitted").size(), 2U) << impostor.output();
    EXPECT_EQ(lines_with(impostor.output(), "renew not permitted").size(), 2U) << impostor.output();
    EXPECT_EQ(lines_with(impostor.output(), "release not permitted").size(), 2U) << impostor.output();
    // Its write never reached the drive, and the lease neither moved nor ended.
    EXPECT_EQ(stack.sim_register(1, "FA00"), 0xC400);
    const auto writes = stack.sim().command("writes 1");
    EXPECT_EQ(writes.find("0xFA00=51200"), std::string::npos) << writes;
    EXPECT_EQ(stack.daemon_output().find("took the control lease over"), std::string::npos) << stack.daemon_output();
    EXPECT_EQ(stack.daemon_output().find("released the control lease"), std::string::npos) << stack.daemon_output();

    // Still the holder's lease: when the holder dies, the drive gets its stop word.
    holder.kill9();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") == 0xC000; }, 10s))
        << "FA00 = " << stack.sim_register(1, "FA00") << "\n"
        << stack.daemon_output();
    EXPECT_NE(stack.daemon_output().find("control lease of test_client_command"), std::string::npos)
        << stack.daemon_output();
}

TEST(Ipc, ClientsNoticeWhenTheDaemonIsGone) {
    Stack stack;
    Client watcher({stack.bus(), "snapshots", "100000"});
    ASSERT_TRUE(watcher.printed("snapshot ", 10s)) << watcher.output();
    stack.stop_daemon();
    // Either the library says so, or iceoryx 2.0 itself ends the client (SIGABRT from its
    // keep-alive once RouDi's socket refuses it: docs/ipc.md, known limit). It never hangs.
    const int status = watcher.wait(15s);
    ASSERT_TRUE(status == 1 || status == 128 + SIGABRT) << status << "\n" << watcher.output();
    if (status == 1) {
        EXPECT_NE(watcher.output().find("daemon gone"), std::string::npos) << watcher.output();
    }
}

std::uint64_t sim_counter(Stack& stack, const std::string& key) {
    const auto stats = stack.sim().command("stats");
    const auto at = stats.find(key + "=");
    return at == std::string::npos ? ~0ULL : std::stoull(stats.substr(at + key.size() + 1));
}

TEST(Ipc, ABroadcastReachesEveryDriveWithoutAReply) {
    StackOptions options;
    options.fan = false;
    Stack stack(options);
    Client c({stack.bus(), "broadcast", "0xFA51", "123"});
    ASSERT_EQ(c.wait(10s), 0) << c.output();
    EXPECT_NE(stack.sim().command("writes 1").find("0xFA51=123"), std::string::npos);
    EXPECT_EQ(sim_counter(stack, "broadcasts"), 1U);
}

TEST(Ipc, ABroadcastThatSomeDriveCannotTakeNeverReachesTheWire) {
    Stack stack;  // the ATV58 has no FA51
    Client c({stack.bus(), "broadcast", "0xFA51", "5"});
    EXPECT_EQ(c.wait(10s), 1) << c.output();
    EXPECT_NE(c.output().find("rejected"), std::string::npos) << c.output();
    EXPECT_EQ(sim_counter(stack, "broadcasts"), 0U);
}

// A second drivebusd: one line and exit status 1, never an abort.
TEST(Ipc, ASecondDaemonSaysWhyItCannotStart) {
    Stack stack;
    const auto embedded = run_program({DRIVEBUSD_PATH, "--config", stack.config().string()});
    EXPECT_EQ(embedded.first, 1) << embedded.second;
    EXPECT_NE(embedded.second.find("a RouDi already runs"), std::string::npos) << embedded.second;

    auto text = stack.config_text();
    text.replace(text.find("roudi = \"embedded\""), 18, "roudi = \"auto\"");
    const auto second = stack.dir() / "second.toml";
    std::ofstream(second) << text;
    const auto joined = run_program({DRIVEBUSD_PATH, "--config", second.string()});
    EXPECT_EQ(joined.first, 1) << joined.second;
    EXPECT_NE(joined.second.find("already served by another drivebusd (pid"), std::string::npos) << joined.second;
    // The first one carries on.
    Client after({stack.bus(), "read", "FD00", "2"});
    EXPECT_EQ(after.wait(10s), 0) << after.output();
}

TEST(Ipc, ExternalWithoutARouDiSaysWhatToStart) {
    const auto dir = std::filesystem::temp_directory_path() / ("drivebus-ext-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "d.toml") << "[realtime]\nmode = \"off\"\n[ipc]\nroudi = \"external\"\n"
                                     "[[bus]]\nname = \"x\"\ndevice = \"/dev/null\"\nparity = \"none\"\n"
                                     "  [[bus.drive]]\n  name = \"pump\"\n  address = 1\n  profile = \"atv21\"\n";
    const auto [status, out] = run_program({DRIVEBUSD_PATH, "--config", (dir / "d.toml").string()});
    std::filesystem::remove_all(dir);
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("no RouDi answers"), std::string::npos) << out;
    EXPECT_NE(out.find("drivebus-roudi.service"), std::string::npos) << out;
}

}  // namespace
}  // namespace drivebus::test
