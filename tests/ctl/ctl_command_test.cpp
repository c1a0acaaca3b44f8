// SPDX-License-Identifier: Apache-2.0
// drivebusctl's writes of the pump's command and reference as processes against the whole stack
// (drivebus-sim, drivebusd): a refused write takes no control lease, a write through the write
// block gives the lease back as a direct one does, and a write past its --deadline is never
// sent. Every test holds the ctest RESOURCE_LOCK "iceoryx".
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "read_json.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

struct Run {
    int status = -1;
    std::string out;
    std::string err;
};

Run ctl(const Stack& stack, std::vector<std::string> args) {
    static int n = 0;
    const auto err_file = fs::temp_directory_path() /
                          ("drivebusctl-cmd-" + std::to_string(::getpid()) + "-" + std::to_string(n++) + ".err");
    std::vector<std::string> argv = {
        "/bin/sh", "-c",       "f=$1; shift; exec \"$@\" 2>\"$f\"", "sh", err_file.string(), DRIVEBUSCTL_PATH,
        "--bus",   stack.bus()};
    argv.insert(argv.end(), args.begin(), args.end());
    auto [status, out] = run_program(argv);
    std::stringstream err;
    err << std::ifstream(err_file).rdbuf();
    std::error_code ec;
    fs::remove(err_file, ec);
    return {status, out, err.str()};
}

std::string describe(const Run& r) {
    return "exit " + std::to_string(r.status) + "\nstdout:\n" + r.out + "stderr:\n" + r.err;
}

std::string lease_state(const Stack& stack) {
    const auto s = ctl(stack, {"--json", "status", "pump"});
    return s.status == 0 ? json::parse(s.out)["lease"]["state"].str() : "status failed: " + describe(s);
}

// The simulator's log of the writes the pump accepted: " 0xFA00=49152 ..."
std::string pump_writes(Stack& stack) {
    return stack.sim().command("writes 1");
}

// The pump with its write block selecting FA00 and FA01, a short lease and the ramp stop as
// fallback, left awaiting the reset after drivebusd's set-up.
StackOptions block_pump() {
    StackOptions o;
    o.paced = false;
    o.reset_pump = false;
    o.drive_extra = "  write_block = [\"FA00\", \"FA01\"]\n  lease = \"300ms\"\n  fallback = \"stop\"\n";
    return o;
}

// Before the pump is power-cycled the block is not applied: drivebusctl's write through it is
// refused (exit 3), and drivebusd holds no lease for it and writes no fallback. Once it is
// applied, the same write takes the lease and drivebusctl gives it back, as after a write of
// FA00 itself: the drive keeps running, and no fallback stops it.
TEST(CtlCommand, AWriteThroughTheBlockTakesAndGivesBackTheLeaseAsADirectOneAndARefusedOneTakesNone) {
    Stack stack(block_pump());
    ASSERT_TRUE(wait_until([&] { return stack.daemon_output().find("awaiting a reset") != std::string::npos; }, 20s))
        << stack.daemon_output();
    const auto refused = ctl(stack, {"write", "pump", "0x1870", "0xC400", "1500"});
    EXPECT_EQ(refused.status, 3) << describe(refused);
    EXPECT_NE(refused.err.find("not applied the indirect block"), std::string::npos) << describe(refused);
    EXPECT_EQ(lease_state(stack), "free") << stack.daemon_output();
    // The lease time passes several times over: no lease runs out, no stop word is written.
    EXPECT_FALSE(wait_until([&] { return stack.daemon_output().find("ran out") != std::string::npos; }, 1500ms))
        << stack.daemon_output();
    EXPECT_EQ(pump_writes(stack).find("0xFA00="), std::string::npos) << pump_writes(stack);

    stack.power_cycle_pump();
    for (const auto& how : std::vector<std::vector<std::string>>{{"write", "pump", "0x1870", "0xC400", "1500"},
                                                                 {"write", "pump", "FA00", "0xC400"}}) {
        const auto r = ctl(stack, how);
        ASSERT_EQ(r.status, 0) << describe(r);
        EXPECT_NE(r.err.find("released the control lease of drive 'pump'"), std::string::npos) << describe(r);
        EXPECT_TRUE(wait_until([&] { return lease_state(stack) == "free"; }, 10s)) << lease_state(stack);
        EXPECT_EQ(stack.sim_register(1, "FA00"), 0xC400);
    }
    EXPECT_EQ(stack.sim_register(1, "FA01"), 1500);
    EXPECT_FALSE(wait_until([&] { return stack.daemon_output().find("ran out") != std::string::npos; }, 1500ms))
        << stack.daemon_output();
    EXPECT_EQ(stack.sim_register(1, "FA00"), 0xC400) << "a fallback stopped the drive";
    EXPECT_EQ(pump_writes(stack).find("0xFA00=49152"), std::string::npos) << pump_writes(stack);
}

// The pump answers 900 ms late, past every attempt's time-out: a write holds the line for all
// its attempts, and one queued behind it with a 100 ms deadline is dropped, never sent (exit 9),
// while one with time enough is sent after it.
TEST(CtlCommand, AWriteNotOnTheWireByItsDeadlineIsNeverSent) {
    StackOptions o;
    o.paced = false;
    o.polls = false;
    Stack stack(o);
    ASSERT_EQ(stack.sim().command("set 1 F803 0").rfind("ok", 0), 0U);
    ASSERT_EQ(stack.sim().command("fault 1 late=900ms").rfind("ok", 0), 0U);
    const auto before = stack.sim_requests();
    test::Run first;
    {
        std::jthread busy([&] { first = ctl(stack, {"--timeout", "10s", "write", "pump", "FA51", "111"}); });
        ASSERT_TRUE(wait_until([&] { return stack.sim_requests() > before; }, 10s)) << "the first write went out";
        const auto late = ctl(stack, {"write", "--deadline", "100ms", "pump", "FA51", "777"});
        EXPECT_EQ(late.status, 9) << describe(late);
        EXPECT_NE(late.err.find("was not on the wire by its deadline"), std::string::npos) << describe(late);
    }
    const auto met = ctl(stack, {"--timeout", "10s", "write", "--deadline", "5s", "pump", "FA51", "222"});
    EXPECT_NE(met.status, 9) << describe(met);
    const auto log = pump_writes(stack);
    EXPECT_EQ(log.find("0xFA51=777"), std::string::npos) << "sent after its deadline: " << log;
    EXPECT_NE(log.find("0xFA51=222"), std::string::npos) << log;
    EXPECT_NE(stack.sim_register(1, "FA51"), 777);
}

}  // namespace
}  // namespace drivebus::test
