// SPDX-License-Identifier: Apache-2.0
// A real-time thread's log lines go into its own ring: a full ring refuses the line at once
// (never waits) and counts it; the drain writes what is waiting and then says how many were
// dropped.
#include <gtest/gtest.h>

#include <string>
#include <thread>

#include "log/log.hpp"

namespace drivebus::test {
namespace {

// A client's name or a device path can hold anything: a newline in it must not start a line
// of its own in the journal (one that could pass for drivebusd's), nor an escape sequence
// reach a terminal.
TEST(LogLine, ControlCharactersCannotStartAnotherLine) {
    EXPECT_EQ(log::one_line("control lease of pump[12]"), "control lease of pump[12]");
    EXPECT_EQ(log::one_line("pump\n<3>drivebusd: error: forged"), "pump\\x0A<3>drivebusd: error: forged");
    EXPECT_EQ(log::one_line("a\rb\x1B[2Jc\x7F"), "a\\x0Db\\x1B[2Jc\\x7F");
    EXPECT_EQ(log::one_line("tab\tend"), "tab\\x09end");
    EXPECT_EQ(log::one_line("\xC3\xA9t\xC3\xA9"), "\xC3\xA9t\xC3\xA9") << "UTF-8 passes unchanged";
}

TEST(LogRing, AFullRingDropsTheLineAndCountsIt) {
    log::Ring ring(4, false);
    for (int i = 0; i < 4; ++i) {
        EXPECT_TRUE(ring.put(log::Level::Info, "line " + std::to_string(i)));
    }
    EXPECT_FALSE(ring.put(log::Level::Error, "one too many"));
    EXPECT_EQ(ring.dropped(), 1U);
    testing::internal::CaptureStderr();
    ring.drain();
    const std::string written = testing::internal::GetCapturedStderr();
    EXPECT_NE(written.find("line 3"), std::string::npos) << written;
    EXPECT_EQ(written.find("one too many"), std::string::npos) << written;
    EXPECT_NE(written.find("1 log lines of a real-time thread dropped"), std::string::npos) << written;
    EXPECT_TRUE(ring.put(log::Level::Info, "room again"));
}

TEST(LogRing, AThreadUsingARingDoesNotWriteItself) {
    log::Ring ring(8, false);
    testing::internal::CaptureStderr();
    std::thread user([&] {
        ring.use_on_this_thread();
        log::write(log::Level::Warning, "from the ring's thread");
    });
    user.join();
    const std::string before_drain = testing::internal::GetCapturedStderr();
    EXPECT_EQ(before_drain.find("from the ring's thread"), std::string::npos) << "written by the thread itself";
    testing::internal::CaptureStderr();
    ring.drain();
    const std::string written = testing::internal::GetCapturedStderr();
    EXPECT_NE(written.find("from the ring's thread"), std::string::npos) << written;
}

}  // namespace
}  // namespace drivebus::test
