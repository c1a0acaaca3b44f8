// SPDX-License-Identifier: Apache-2.0
// iceoryx's own output taken line by line: its logger's coloured lines become a priority and a
// plain text, its failed calls on std::cerr are recognised even when written in pieces, and
// what is not iceoryx's passes through unchanged. The lines below are what iceoryx 2.0.3 printed
// here when drivebusd stopped under a running drivebusctl.
#include <gtest/gtest.h>

#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "log/log.hpp"
#include "log/stream_lines.hpp"

namespace drivebus::test {
namespace {

const std::string kError =
    "\x1B[0;90m2026-12-02 09:23:09.382 \x1B[0;1;31;103m[ Error ]\x1B[m: Could not send request "
    "via RouDi IPC channel interface.";
const std::string kFailedCall =
    "./iceoryx_hoofs/source/posix_wrapper/unix_domain_socket.cpp:249 { iox::cxx::expected<iox::posix::IpcChannelError> "
    "iox::posix::UnixDomainSocket::timedSend(const std::string&, const iox::units::Duration&) const -> iox_sendto }  "
    ":::  [ 111 ]  Connection refused";

TEST(IceoryxLines, TheLoggersLineGivesItsPriorityAndText) {
    const auto error = log::parse_iceoryx_message(kError);
    ASSERT_TRUE(error);
    EXPECT_EQ(error->priority, 3);
    EXPECT_EQ(error->text, "Could not send request via RouDi IPC channel interface.");
    const std::vector<std::pair<std::string, int>> levels{{"\x1B[0;1;97;41m[ Fatal ]", 2},
                                                          {"\x1B[0;1;93m[Warning]", 4},
                                                          {"\x1B[0;1;92m[ Info  ]", 6},
                                                          {"\x1B[0;1;96m[ Debug ]", 7},
                                                          {"\x1B[0;1;36m[Verbose]", 7}};
    for (const auto& [tag, priority] : levels) {
        const auto m = log::parse_iceoryx_message("\x1B[0;90m2026-12-02 09:23:09.382 " + tag + "\x1B[m: text ");
        ASSERT_TRUE(m) << tag;
        EXPECT_EQ(m->priority, priority) << tag;
        EXPECT_EQ(m->text, "text");
    }
    EXPECT_FALSE(log::parse_iceoryx_message("Reserving 65797528 bytes in the shared memory [iceoryx_mgmt]"));
    EXPECT_FALSE(log::parse_iceoryx_message("\x1B[0;90mnot a time stamp [ Error ]\x1B[m: x"));
}

TEST(IceoryxLines, EscapesAreRemoved) {
    EXPECT_EQ(log::without_escapes("\x1B[0;1;31;103m[ Error ]\x1B[m: x"), "[ Error ]: x");
    EXPECT_EQ(log::without_escapes("a\x1B"
                                   "cb\x1B[Kc"),
              "abc");
    EXPECT_EQ(log::without_escapes("plain"), "plain");
}

TEST(IceoryxLines, WhichLinesAreIceoryxs) {
    EXPECT_TRUE(log::is_iceoryx_line(kError));
    EXPECT_TRUE(log::is_iceoryx_line(kFailedCall));
    EXPECT_TRUE(log::is_iceoryx_line("internal logic error in unix domain socket \"/tmp/roudi\" occurred"));
    EXPECT_FALSE(log::is_iceoryx_line("drivebusctl: drivebusd has gone silent (no bus status); watch ended"));
    EXPECT_FALSE(log::is_iceoryx_line("main.cpp:12 { x }  :::  [ 1 ]  an application's own line"));
    // Beginnings that may still become one, as std::cerr flushes them piece by piece.
    EXPECT_TRUE(log::may_become_iceoryx_line("./iceoryx_hoofs/source/posix_wrapper/unix_domain_socket.cpp"));
    EXPECT_TRUE(log::may_become_iceoryx_line("\x1B[0;90m"));
    EXPECT_TRUE(log::may_become_iceoryx_line("internal logic"));
    EXPECT_FALSE(log::may_become_iceoryx_line("Enter a speed: "));
}

// libdrivebus's use: iceoryx's lines are taken, an application's own text passes through as it
// was written, a prompt without its newline included.
TEST(LineRouter, TakesIceoryxsLinesAndPassesTheRestThrough) {
    std::stringbuf terminal;
    std::vector<std::string> taken;
    log::LineRouter router(
        [&](std::string_view line) {
            if (!log::is_iceoryx_line(line)) {
                return false;
            }
            taken.emplace_back(line);
            return true;
        },
        &terminal, log::may_become_iceoryx_line);
    std::ostream err(&router);
    err.setf(std::ios::unitbuf);  // as std::cerr: flushed after every output
    err << "./iceoryx_hoofs/source/posix_wrapper/unix_domain_socket.cpp" << ":" << 249
        << " { iox::cxx::expected<iox::posix::IpcChannelError> iox::posix::UnixDomainSocket::timedSend(const "
           "std::string&, const iox::units::Duration&) const -> iox_sendto }  :::  [ "
        << 111 << " ]  " << "Connection refused" << std::endl;
    // The logger writes its line in one piece, with the newline the message ends with.
    err << kError + "\n\n";
    EXPECT_EQ(terminal.str(), "");
    err << "Enter a speed: ";
    EXPECT_EQ(terminal.str(), "Enter a speed: ") << "a prompt is not held back";
    err << "40 Hz\n" << std::endl;
    EXPECT_EQ(terminal.str(), "Enter a speed: 40 Hz\n\n") << "an application's empty line is its own";
    ASSERT_EQ(taken.size(), 2U);
    EXPECT_EQ(taken[0], kFailedCall);
    EXPECT_EQ(taken[1], kError);
}

class Recorder final : public log::Backend {
public:
    int send(std::span<const iovec> /*fields*/) noexcept override { return -1; }
    void print(std::string_view line) noexcept override { printed.emplace_back(line); }
    std::vector<std::string> printed;
};

// drivebusd's use: every line on the three streams goes through the log, none to stdout.
TEST(RouteStandardStreams, IceoryxsLinesBecomeLogLinesAtTheirPriority) {
    Recorder recorder;
    log::set_backend(&recorder);
    log::init("drivebusd", log::Level::Debug);
    log::route_standard_streams();
    std::clog << kError + "\n\n";
    std::cerr << kFailedCall << std::endl;
    std::clog << "Reserving 65797528 bytes in the shared memory [iceoryx_mgmt]" << std::endl;
    std::cout << "RouDi is ready for clients" << std::endl;
    log::set_backend(nullptr);
    const std::vector<std::string> expected{
        "drivebusd: error: iceoryx: Could not send request via RouDi IPC channel interface.\n",
        "drivebusd: warning: iceoryx: " + kFailedCall + "\n",
        "drivebusd: debug: Reserving 65797528 bytes in the shared memory [iceoryx_mgmt]\n",
        "drivebusd: debug: RouDi is ready for clients\n",
    };
    EXPECT_EQ(recorder.printed, expected);
}

}  // namespace
}  // namespace drivebus::test
