// SPDX-License-Identifier: Apache-2.0
#include "sys/event_loop.hpp"

#include <sys/epoll.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <array>
#include <stdexcept>

namespace drivebus::sys {

EventLoop::EventLoop() {
    auto fd = posix_call("epoll_create1", [] { return ::epoll_create1(EPOLL_CLOEXEC); });
    if (!fd) {
        throw std::runtime_error(fd.error().message());
    }
    epoll_.reset(*fd);
}

std::expected<void, SysError> EventLoop::add(int fd, std::function<void()> on_ready) {
    return add(fd, [f = std::move(on_ready)](Readiness) { f(); });
}

std::expected<void, SysError> EventLoop::add(int fd, std::function<void(Readiness)> on_ready) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    if (auto ok = posix_call("epoll_ctl", [&] { return ::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, fd, &ev); }); !ok) {
        return std::unexpected(ok.error());
    }
    handlers_[fd] = std::make_shared<std::function<void(Readiness)>>(std::move(on_ready));
    return {};
}

std::expected<void, SysError> EventLoop::watch_writable(int fd, bool on) {
    return watch(fd, true, on);
}

std::expected<void, SysError> EventLoop::watch(int fd, bool readable, bool writable) {
    epoll_event ev{};
    ev.events = (readable ? EPOLLIN : 0U) | (writable ? EPOLLOUT : 0U);
    ev.data.fd = fd;
    auto ok = posix_call("epoll_ctl", [&] { return ::epoll_ctl(epoll_.get(), EPOLL_CTL_MOD, fd, &ev); });
    if (!ok) {
        return std::unexpected(ok.error());
    }
    return {};
}

void EventLoop::remove(int fd) {
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, fd, nullptr);
    handlers_.erase(fd);
}

std::expected<void, SysError> EventLoop::run() {
    running_ = true;
    std::array<epoll_event, 16> events{};
    while (running_) {
        auto n = posix_call("epoll_wait", [&] {
            return ::epoll_wait(epoll_.get(), events.data(), static_cast<int>(events.size()), -1);
        });
        if (!n) {
            return std::unexpected(n.error());
        }
        for (int i = 0; i < *n && running_; ++i) {
            const epoll_event& event = events[static_cast<std::size_t>(i)];
            const auto it = handlers_.find(event.data.fd);
            if (it != handlers_.end()) {
                const auto handler = it->second;  // a handler may remove itself
                (*handler)(Readiness{(event.events & EPOLLIN) != 0, (event.events & (EPOLLHUP | EPOLLERR)) != 0,
                                     (event.events & EPOLLOUT) != 0});
            }
        }
    }
    return {};
}

Timer::Timer() {
    auto fd =
        posix_call("timerfd_create", [] { return ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC); });
    if (!fd) {
        throw std::runtime_error(fd.error().message());
    }
    fd_.reset(*fd);
}

std::expected<void, SysError> Timer::arm(rtu::Instant at) {
    itimerspec spec{};
    spec.it_value = to_timespec(at);
    if (spec.it_value.tv_sec == 0 && spec.it_value.tv_nsec == 0) {
        spec.it_value.tv_nsec = 1;  // zero would disarm
    }
    auto ok =
        posix_call("timerfd_settime", [&] { return ::timerfd_settime(fd_.get(), TFD_TIMER_ABSTIME, &spec, nullptr); });
    if (!ok) {
        return std::unexpected(ok.error());
    }
    return {};
}

void Timer::disarm() noexcept {
    // Disarming a timerfd this object owns cannot fail (zero is always a valid value).
    const itimerspec spec{};
    ::timerfd_settime(fd_.get(), 0, &spec, nullptr);
}

void Timer::acknowledge() noexcept {
    std::uint64_t expirations = 0;
    [[maybe_unused]] const auto n = ::read(fd_.get(), &expirations, sizeof expirations);
}

}  // namespace drivebus::sys
