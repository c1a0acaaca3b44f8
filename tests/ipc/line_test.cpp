// SPDX-License-Identifier: Apache-2.0
// The line as drivebusd reports and recovers it: an adapter that stays present and delivers
// nothing (drivebus-sim's `mute`, which lasts until the port is opened again) is reopened and
// the drives come back without restarting drivebusd; a line that is down shows no drive online.
#include <gtest/gtest.h>

#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

std::string status(const Stack& stack) {
    return run_program({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "status"}).second;
}

bool contains(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

// A bus counter's value in `drivebusctl status`'s text ("mute reopens  2").
std::uint64_t counter(const std::string& text, const std::string& name) {
    const auto at = text.find("\n  " + name + " ");
    if (at == std::string::npos) {
        return 0;
    }
    return std::stoull(text.substr(text.find_first_of("0123456789", at + name.size() + 3)));
}

std::uint64_t mute_reopens(const std::string& text) {
    return counter(text, "mute reopens");
}

TEST(Line, AMuteAdapterIsReopenedAndTheDrivesComeBack) {
    StackOptions options;
    options.bus_extra = "mute_reopen = \"1s\"\n";
    Stack stack(options);
    ASSERT_TRUE(wait_until([&] { return contains(status(stack), "2 of 2 online"); }, 10s)) << status(stack);
    EXPECT_EQ(mute_reopens(status(stack)), 0U) << status(stack);
    ASSERT_EQ(stack.sim().command("mute"), "ok");
    // Every drive falls silent; drivebusd reopens the port, which ends the simulator's mute.
    ASSERT_TRUE(wait_until(
        [&] {
            return contains(stack.daemon_output(),
                            "while every request timed out; "
                            "reopening the port");
        },
        20s))
        << stack.daemon_output();
    ASSERT_TRUE(wait_until([&] { return contains(stack.sim().output(), "no longer mute"); }, 10s))
        << stack.sim().output();
    ASSERT_TRUE(wait_until([&] { return contains(status(stack), "2 of 2 online"); }, 30s)) << status(stack) << "\n"
                                                                                           << stack.daemon_output();
    EXPECT_GE(mute_reopens(status(stack)), 1U) << status(stack);
    EXPECT_TRUE(contains(status(stack), "up")) << status(stack);
}

TEST(Line, WithMuteReopenOffAMuteAdapterStaysMute) {
    StackOptions options;
    options.bus_extra = "mute_reopen = \"off\"\n";
    Stack stack(options);
    ASSERT_TRUE(wait_until([&] { return contains(status(stack), "2 of 2 online"); }, 10s)) << status(stack);
    ASSERT_EQ(stack.sim().command("mute"), "ok");
    ASSERT_TRUE(wait_until([&] { return contains(status(stack), "0 of 2 online"); }, 20s)) << status(stack);
    // drivebusd goes on asking (the absent drives' probes time out): at 1 s, as the test
    // above, it would have reopened the port by the time four more are counted (their back-off
    // makes that several seconds).
    const auto timeouts = counter(status(stack), "timeouts");
    ASSERT_TRUE(wait_until([&] { return counter(status(stack), "timeouts") >= timeouts + 4; }, 30s)) << status(stack);
    EXPECT_FALSE(contains(stack.daemon_output(), "reopening the port")) << stack.daemon_output();
    EXPECT_EQ(mute_reopens(status(stack)), 0U) << status(stack);
}

// The simulator gone: the line is down, and drivebusctl says so, with no drive online.
TEST(Line, ALineThatIsDownShowsNoDriveOnline) {
    Stack stack;
    ASSERT_TRUE(wait_until([&] { return contains(status(stack), "2 of 2 online"); }, 10s)) << status(stack);
    (void)stack.sim().stop();
    ASSERT_TRUE(wait_until([&] { return contains(status(stack), "down"); }, 10s)) << status(stack);
    const auto down = status(stack);
    EXPECT_TRUE(contains(down, "0 of 2 online")) << down;
    const auto pump = run_program({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "status", "pump"}).second;
    EXPECT_FALSE(contains(pump, "online")) << pump;
}

}  // namespace
}  // namespace drivebus::test
