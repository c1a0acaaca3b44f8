// SPDX-License-Identifier: Apache-2.0
// Lines that other code writes on std::cout, std::clog and std::cerr, taken line by line. iceoryx
// 2.0.3 has no hook for its log output: its logger prints each message on std::clog, coloured
// with ANSI escapes ("ESC[0;90m2026-12-02 09:23:09.382 ESC[0;1;31;103m[ Error ]ESC[m: text"), a
// failed system call is one line on std::cerr ("./iceoryx_hoofs/...cpp:249 { ... -> iox_sendto }
// :::  [ 111 ]  Connection refused"), shared memory set-up is two plain lines on std::clog
// ("Reserving N bytes in the shared memory [name]") and its RouDi says "RouDi is ready for
// clients" on std::cout. A LineRouter put in as one of those streams' buffer sees every such
// line: drivebusd writes them through its log, libdrivebus keeps them off its applications'
// terminals.
#pragma once

#include <functional>
#include <mutex>
#include <optional>
#include <streambuf>
#include <string>
#include <string_view>

namespace drivebus::log {

// `text` without its ANSI escape sequences (CSI "ESC[...X" and two-character "ESC X").
[[nodiscard]] std::string without_escapes(std::string_view text);

// One message of iceoryx's logger: its syslog priority (fatal 2, error 3, warning 4, info 6,
// debug and verbose 7) and its text, escapes and time stamp removed. nullopt: not one.
struct IceoryxMessage {
    int priority = 6;
    std::string text;
};
[[nodiscard]] std::optional<IceoryxMessage> parse_iceoryx_message(std::string_view line);

// Whether `line` is one of iceoryx's: a message of its logger, a failed system call it reports
// on std::cerr, or one of its other diagnostics there.
[[nodiscard]] bool is_iceoryx_line(std::string_view line);
// Whether `start`, the beginning of a line not ended yet, may become one of iceoryx's (it
// writes a failed call's line in pieces, and std::cerr flushes after each).
[[nodiscard]] bool may_become_iceoryx_line(std::string_view start);

// A stream buffer that hands each complete line (without its newline) to `on_line`. With
// `through`, a line `on_line` does not take (returns false) is written there unchanged, and a
// flush passes on what is waiting unless `hold` says the line may still become one that
// `on_line` takes. Safe to use from several threads (a line is collected under a mutex).
class LineRouter final : public std::streambuf {
public:
    using OnLine = std::function<bool(std::string_view line)>;
    using Hold = std::function<bool(std::string_view start)>;
    explicit LineRouter(OnLine on_line, std::streambuf* through = nullptr, Hold hold = {});

protected:
    int_type overflow(int_type c) override;
    std::streamsize xsputn(const char* s, std::streamsize n) override;
    int sync() override;

private:
    void take(std::string_view text);  // with mutex_ held

    OnLine on_line_;
    std::streambuf* through_;
    Hold hold_;
    std::mutex mutex_;
    std::string pending_;
};

}  // namespace drivebus::log
