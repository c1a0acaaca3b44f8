// SPDX-License-Identifier: Apache-2.0
// The registers drivebusd relies on and the indirect blocks, against the running stack
// (drivebus-sim, drivebusd, drivebusctl, each its own process): a client can neither rewrite a
// selector of the read block (which made every later snapshot publish the output current as
// the output frequency) nor reach the command or reference through the write block while
// another client holds the lease. Each refusal is typed and one line, and the simulator's own
// registers and write log show that nothing reached the drive.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

constexpr int kExitRejected = 3;
constexpr int kExitNotPermitted = 4;

std::pair<int, std::string> ctl(const Stack& stack, std::vector<std::string> args) {
    args.insert(args.begin(), {DRIVEBUSCTL_PATH, "--bus", stack.bus()});
    return run_program(args);
}

std::size_t lines(const std::string& text) {
    std::size_t n = 0;
    for (const char c : text) {
        n += c == '\n' ? 1 : 0;
    }
    return n + (!text.empty() && text.back() != '\n' ? 1 : 0);
}

// The drive's set-up has reached the simulated drive: F875-F879 select what the pump's indirect
// poll reads (FD00 = 2, FD01 = 1, FE03 = 3, FE05 = 4, FC91 = 5).
void expect_read_block_set_up(const Stack& stack) {
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "F879") == 5; }, 10s)) << stack.daemon_output();
    EXPECT_EQ(stack.sim_register(1, "F875"), 2);
    EXPECT_EQ(stack.sim_register(1, "F876"), 1);
}

// Finding 1: `drivebusctl write pump F875 3` returned 0, and from then on the read block
// returned FE03 (output current) in the slot drivebusd publishes as FD00 (output frequency).
TEST(Ownership, ASelectorOfTheReadBlockIsRefusedAndNeverReachesTheDrive) {
    Stack stack;
    expect_read_block_set_up(stack);
    const auto [status, out] = ctl(stack, {"write", "pump", "F875", "3"});
    EXPECT_EQ(status, kExitRejected) << out;
    EXPECT_NE(out.find("F875 is owned by drivebusd: selector of the read block at 0x1875"), std::string::npos) << out;
    EXPECT_EQ(lines(out), 1U) << out;
    const auto [write_status, write_out] = ctl(stack, {"write", "pump", "F870", "3"});
    EXPECT_EQ(write_status, kExitRejected) << write_out;
    EXPECT_NE(write_out.find("F870 is owned by drivebusd: selector of the write block at 0x1870"), std::string::npos)
        << write_out;
    // The drive still holds what drivebusd wrote, and its write log has no client's selector.
    EXPECT_EQ(stack.sim_register(1, "F875"), 2);
    EXPECT_EQ(stack.sim_register(1, "F870"), 0);
    const auto writes = stack.sim().command("writes 1");
    EXPECT_EQ(writes.find("0x0875=3"), std::string::npos) << writes;
    EXPECT_EQ(writes.find("0x0870="), std::string::npos) << writes;
    // Reading a selector changes nothing, and is allowed.
    const auto [read_status, read_out] = ctl(stack, {"read", "pump", "F875"});
    EXPECT_EQ(read_status, 0) << read_out;
    EXPECT_NE(stack.daemon_output().find("F875 is owned by drivebusd"), std::string::npos) << stack.daemon_output();
}

// Without write_block, drivebusd never wrote F870/F871: what the write block reaches is unknown
// to it, so a client's write through the block is refused, whatever the selectors hold.
TEST(Ownership, AWriteThroughABlockDrivebusdHasNotSetUpIsRefused) {
    Stack stack;
    expect_read_block_set_up(stack);
    ASSERT_EQ(stack.sim().command("set 1 F870 1"), "ok");
    ASSERT_EQ(stack.sim().command("set 1 F871 3"), "ok");
    const auto [status, out] = ctl(stack, {"write", "pump", "0x1870", "0xC400", "1500"});
    EXPECT_EQ(status, kExitRejected) << out;
    EXPECT_NE(out.find("the write block at 0x1870 is not set up by drivebusd"), std::string::npos) << out;
    EXPECT_EQ(lines(out), 1U) << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 0);
    EXPECT_EQ(stack.sim_register(1, "FA00"), 0);
    EXPECT_EQ(stack.sim().command("writes 1").find("0x1870="), std::string::npos);
}

// Finding 2: while one client held the pump's lease, another's write through 0x1870 (F870/F871
// selecting FA00/FA01) returned 0 and set FA01. The write is now expanded to FA00 and FA01,
// and the lease applies to them.
TEST(Ownership, TheLeaseCoversTheCommandAndReferenceReachedThroughTheWriteBlock) {
    StackOptions options;
    options.drive_extra = "  lease = \"300ms\"\n  write_block = [\"FA00\", \"FA01\"]\n";
    Stack stack(options);
    expect_read_block_set_up(stack);
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "F871") == 3; }, 10s)) << stack.daemon_output();
    EXPECT_EQ(stack.sim_register(1, "F870"), 1);
    Child holder({TEST_CLIENT_PATH, stack.bus(), "command", "30"});
    ASSERT_TRUE(wait_until([&] { return holder.output().find("holding") != std::string::npos; }, 10s))
        << holder.output();
    const auto [status, out] = ctl(stack, {"write", "pump", "0x1870", "0xC400", "1500"});
    EXPECT_EQ(status, kExitNotPermitted) << out;
    EXPECT_EQ(lines(out), 1U) << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000);
    const auto writes = stack.sim().command("writes 1");
    EXPECT_EQ(writes.find("0x1871=1500"), std::string::npos) << writes;
    EXPECT_EQ(writes.find("0xFA01=1500"), std::string::npos) << writes;
    // Taking the lease over, the same write goes through the block to FA00 and FA01.
    const auto [taken_status, taken_out] = ctl(stack, {"write", "--take-over", "pump", "0x1870", "0xC400", "1500"});
    EXPECT_EQ(taken_status, 0) << taken_out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 1500);
    EXPECT_NE(stack.daemon_output().find("took the control lease over"), std::string::npos) << stack.daemon_output();
}

// Finding 3: the ATV21 applies F875-F879 only after a reset (guide section 6). A drive fresh
// from the factory gets its selectors written, and then awaits a reset: drivebusd says so in
// its log and in the drive's health, publishes nothing read through the block, and refuses a
// client's read through it (the drive would answer with its old selection). Switched off and
// on, the drive is confirmed and polled, and the block reads what the selectors choose.
TEST(Ownership, ADriveAwaitingAResetIsShownAndRefusesRequestsThroughItsBlock) {
    StackOptions options;
    options.reset_pump = false;
    Stack stack(options);
    expect_read_block_set_up(stack);
    ASSERT_TRUE(wait_until(
        [&] { return stack.daemon_output().find("drive pump: awaiting a reset") != std::string::npos; }, 20s))
        << stack.daemon_output();
    const auto log = stack.daemon_output();
    EXPECT_NE(log.find("the drive applies F875-F879 only after a reset: power-cycle it"), std::string::npos) << log;
    const auto [list_status, list_out] = ctl(stack, {"list"});
    EXPECT_EQ(list_status, 0) << list_out;
    EXPECT_NE(list_out.find("awaiting reset"), std::string::npos) << list_out;
    const auto [status, out] = ctl(stack, {"read", "pump", "0x1875", "5"});
    EXPECT_EQ(status, kExitRejected) << out;
    EXPECT_NE(out.find("the drive has not applied the indirect block's selectors yet (it awaits a reset"),
              std::string::npos)
        << out;
    EXPECT_EQ(lines(out), 1U) << out;
    // A register read on its own is no block: it goes through.
    const auto [direct_status, direct_out] = ctl(stack, {"read", "pump", "FD01"});
    EXPECT_EQ(direct_status, 0) << direct_out;

    stack.power_cycle_pump();
    const auto [online_status, online_out] = ctl(stack, {"list"});
    EXPECT_EQ(online_status, 0) << online_out;
    EXPECT_EQ(online_out.find("awaiting reset"), std::string::npos) << online_out;
    const auto [block_status, block_out] = ctl(stack, {"--json", "read", "pump", "0x1875", "2"});
    EXPECT_EQ(block_status, 0) << block_out;
    // Slot 2 is FD01, the status word: ready (bit 14), as the drive holds it.
    EXPECT_NE(block_out.find(std::to_string(stack.sim_register(1, "FD01"))), std::string::npos) << block_out;
}

// Finding 8: the Altivar 58's profile gives no stop word, so its lease can only hold; drivebusd
// says so at start-up for that drive, and not for the Altivar 21 beside it.
TEST(Ownership, DrivebusdWarnsAtStartUpOfADriveWhoseLeaseCanOnlyHold) {
    Stack stack;
    const auto out = stack.daemon_output();
    EXPECT_NE(out.find("drive 'fan': profile 'atv58' gives no stop or freewheel command word"), std::string::npos)
        << out;
    EXPECT_EQ(out.find("drive 'pump': profile"), std::string::npos) << out;
}

}  // namespace
}  // namespace drivebus::test
