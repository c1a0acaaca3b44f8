// SPDX-License-Identifier: Apache-2.0
// Every system call whose result the code acts on goes through posix_call(): EINTR is retried,
// a failure becomes a typed error that keeps errno and names the call. Called directly, on
// purpose, and nowhere else:
//   - close(), which must not be retried on EINTR on Linux (the descriptor is gone either way);
//   - clean-ups whose failure changes nothing: unlinking our own lock or temporary file,
//     EPOLL_CTL_DEL of a descriptor being closed, disarming a timer, emptying a timerfd that
//     fired, TIOCNXCL and tcflush on a port being closed or drained;
//   - writing to and draining an eventfd (sys::EventFd says why neither can fail usefully), and
//     sending and draining wake-ups (sys/wake.hpp), whose errors are read where they matter;
//   - questions whose failure is the answer: kill(pid, 0) as a liveness probe (EPERM: alive),
//     access() and stat() of a path to tell a user what is missing;
//   - the terminal's own read and write in drivebusctl watch, which handle EINTR themselves;
//   - calls that return an error number instead of setting errno (ttyname_r, ptsname_r) or
//     that touch no kernel object (cfsetispeed, cfsetospeed, cfmakeraw), and calls that cannot
//     fail (getpid, geteuid, getegid; the group database's lookups, whose null is the answer).
#pragma once

#include <cerrno>
#include <ctime>
#include <expected>
#include <string>
#include <system_error>
#include <utility>

#include "rtu/timing.hpp"

namespace drivebus::sys {

struct SysError {
    const char* call = "";                      // the syscall, e.g. "open"
    int error = 0;                              // errno
    [[nodiscard]] std::string message() const;  // "open: No such file or directory"
};

// Calls `f` until it does not fail with EINTR. `f` returns -1 (or a negative value) and sets
// errno on failure, as POSIX calls do.
template <typename F>
auto posix_call(const char* name, F&& f) -> std::expected<decltype(f()), SysError> {
    for (;;) {
        auto result = f();
        if (result >= 0) {
            return result;
        }
        if (errno != EINTR) {
            return std::unexpected(SysError{name, errno});
        }
    }
}

// A file descriptor that is closed when its owner goes. Move-only.
class UniqueFd {
public:
    UniqueFd() = default;
    explicit UniqueFd(int fd) noexcept : fd_(fd) {}
    UniqueFd(UniqueFd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
    UniqueFd& operator=(UniqueFd&& other) noexcept {
        if (this != &other) {
            reset(std::exchange(other.fd_, -1));
        }
        return *this;
    }
    UniqueFd(const UniqueFd&) = delete;
    UniqueFd& operator=(const UniqueFd&) = delete;
    ~UniqueFd() { reset(); }

    [[nodiscard]] int get() const noexcept { return fd_; }
    [[nodiscard]] bool valid() const noexcept { return fd_ >= 0; }
    explicit operator bool() const noexcept { return valid(); }
    int release() noexcept { return std::exchange(fd_, -1); }
    void reset(int fd = -1) noexcept;

private:
    int fd_ = -1;
};

// CLOCK_MONOTONIC, which std::chrono::steady_clock is on Linux.
[[nodiscard]] rtu::Instant now() noexcept;
[[nodiscard]] timespec to_timespec(rtu::Instant t) noexcept;
[[nodiscard]] timespec to_timespec(rtu::Duration d) noexcept;

}  // namespace drivebus::sys
