// SPDX-License-Identifier: Apache-2.0
// A minimal epoll loop: file descriptors with a callback each. Timers are timerfds with
// absolute CLOCK_MONOTONIC deadlines (Timer below); signals arrive through a signalfd.
#pragma once

#include <functional>
#include <map>
#include <memory>

#include "sys/posix.hpp"

namespace drivebus::sys {

// What epoll said about a descriptor. A tty whose device went away (an unplugged USB adapter,
// vhangup()) reports EPOLLHUP and EPOLLERR on every wait from then on, along with EPOLLIN.
struct Readiness {
    bool readable = false;
    bool hung_up = false;   // EPOLLHUP or EPOLLERR
    bool writable = false;  // EPOLLOUT, while watch_writable() asks for it
};

class EventLoop {
public:
    EventLoop();

    // Calls `on_ready` whenever `fd` is readable (or hung up). The loop does not own `fd`.
    // Fails as epoll_ctl does (ENOMEM, ENOSPC: the user's max_user_watches): the caller says
    // what it was adding, since it is called on the bus thread too, where nothing may throw.
    [[nodiscard]] std::expected<void, SysError> add(int fd, std::function<void()> on_ready);
    // The same, telling the callback which: a descriptor that has hung up stays ready, so its
    // owner must close it rather than read on.
    [[nodiscard]] std::expected<void, SysError> add(int fd, std::function<void(Readiness)> on_ready);
    void remove(int fd);
    // Whether `fd`'s callback is also called when it can be written (EPOLLOUT): for a writer
    // whose output buffer was full, so that it waits in the loop instead of beside it.
    std::expected<void, SysError> watch_writable(int fd, bool on);
    // Which of readable and writable `fd`'s callback is called for (a hang-up always is): a
    // reader that may take no more for now (its queue is full) stops watching instead of
    // being woken again and again by what waits in the kernel.
    std::expected<void, SysError> watch(int fd, bool readable, bool writable);
    // Runs until stop(); returns the error that ended it, if any.
    std::expected<void, SysError> run();
    void stop() noexcept { running_ = false; }

private:
    UniqueFd epoll_;
    std::map<int, std::shared_ptr<std::function<void(Readiness)>>> handlers_;
    bool running_ = false;
};

// A one-shot timerfd armed at absolute monotonic times.
class Timer {
public:
    Timer();
    [[nodiscard]] int fd() const noexcept { return fd_.get(); }
    // Fails only as timerfd_settime does (an instant it cannot take).
    [[nodiscard]] std::expected<void, SysError> arm(rtu::Instant at);
    void disarm() noexcept;
    // Reads the expiry count (call from the readable callback).
    void acknowledge() noexcept;

private:
    UniqueFd fd_;
};

}  // namespace drivebus::sys
