// SPDX-License-Identifier: Apache-2.0
// The terminal for drivebusctl watch: keys one at a time without echo (stdin a tty), the
// cursor hidden (stdout a tty), and SIGINT, SIGTERM and SIGHUP turned into a readable pipe.
// Everything is restored when the Terminal goes, whichever way the command ends.
#pragma once

#include <termios.h>

#include <chrono>
#include <optional>
#include <string_view>

namespace drivebus::ctl {

class Terminal {
public:
    Terminal();
    ~Terminal();
    Terminal(const Terminal&) = delete;
    Terminal& operator=(const Terminal&) = delete;
    Terminal(Terminal&&) = delete;
    Terminal& operator=(Terminal&&) = delete;

    [[nodiscard]] bool input_is_tty() const noexcept { return saved_input_.has_value(); }
    [[nodiscard]] bool output_is_tty() const noexcept { return output_tty_; }

    enum class Event { Timeout, Quit };
    // Waits up to `timeout` for q, Ctrl-C or Ctrl-D on the terminal, or a signal.
    [[nodiscard]] Event wait(std::chrono::milliseconds timeout);

    // Writes all of `text` to stdout; false when stdout has gone (a closed pipe).
    [[nodiscard]] static bool write(std::string_view text);

private:
    std::optional<termios> saved_input_;
    bool output_tty_ = false;
    bool cursor_hidden_ = false;
};

}  // namespace drivebus::ctl
