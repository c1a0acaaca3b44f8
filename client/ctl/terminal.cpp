// SPDX-License-Identifier: Apache-2.0
#include "terminal.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <string_view>

namespace drivebus::ctl {
namespace {

int signal_pipe[2] = {-1, -1};

extern "C" void on_signal(int /*signal*/) {
    const int saved = errno;
    const char byte = 1;
    (void)!::write(signal_pipe[1], &byte, 1);
    errno = saved;
}

constexpr std::string_view kHideCursor = "\x1b[?25l";
constexpr std::string_view kShowCursor = "\x1b[?25h";

}  // namespace

Terminal::Terminal() {
    if (signal_pipe[0] < 0 && ::pipe2(signal_pipe, O_CLOEXEC | O_NONBLOCK) != 0) {
        signal_pipe[0] = signal_pipe[1] = -1;
    }
    struct sigaction action{};
    action.sa_handler = on_signal;
    ::sigemptyset(&action.sa_mask);
    for (const int s : {SIGINT, SIGTERM, SIGHUP}) {
        ::sigaction(s, &action, nullptr);
    }
    ::signal(SIGPIPE, SIG_IGN);  // a closed stdout shows as a failed write

    termios mode{};
    if (::isatty(STDIN_FILENO) != 0 && ::tcgetattr(STDIN_FILENO, &mode) == 0) {
        saved_input_ = mode;
        // Keys one at a time, no echo; ISIG stays on, so Ctrl-C is still SIGINT.
        mode.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
        mode.c_cc[VMIN] = 1;
        mode.c_cc[VTIME] = 0;
        ::tcsetattr(STDIN_FILENO, TCSANOW, &mode);
    }
    output_tty_ = ::isatty(STDOUT_FILENO) != 0;
    if (output_tty_) {
        cursor_hidden_ = write(kHideCursor);
    }
}

Terminal::~Terminal() {
    if (cursor_hidden_) {
        (void)write(kShowCursor);
    }
    if (saved_input_) {
        ::tcsetattr(STDIN_FILENO, TCSANOW, &*saved_input_);
    }
    struct sigaction action{};
    action.sa_handler = SIG_DFL;
    ::sigemptyset(&action.sa_mask);
    for (const int s : {SIGINT, SIGTERM, SIGHUP}) {
        ::sigaction(s, &action, nullptr);
    }
}

Terminal::Event Terminal::wait(std::chrono::milliseconds timeout) {
    std::array<pollfd, 2> fds{};
    fds[0] = {signal_pipe[0], POLLIN, 0};
    fds[1] = {saved_input_ ? STDIN_FILENO : -1, POLLIN, 0};
    const auto rc = ::poll(fds.data(), fds.size(), static_cast<int>(timeout.count()));
    if (rc <= 0) {
        return rc < 0 && errno != EINTR ? Event::Quit : Event::Timeout;
    }
    if ((fds[0].revents & POLLIN) != 0) {
        return Event::Quit;
    }
    if ((fds[1].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
        char keys[32];
        const auto n = ::read(STDIN_FILENO, keys, sizeof keys);
        if (n <= 0) {
            return Event::Quit;  // the terminal went away
        }
        for (ssize_t i = 0; i < n; ++i) {
            if (keys[i] == 'q' || keys[i] == 'Q' || keys[i] == '\x03' || keys[i] == '\x04') {
                return Event::Quit;
            }
        }
    }
    return Event::Timeout;
}

bool Terminal::write(std::string_view text) {
    while (!text.empty()) {
        const auto n = ::write(STDOUT_FILENO, text.data(), text.size());
        if (n < 0 && errno == EINTR) {
            continue;
        }
        if (n <= 0) {
            return false;
        }
        text.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
}

}  // namespace drivebus::ctl
