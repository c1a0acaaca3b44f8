// SPDX-License-Identifier: Apache-2.0
// A non-blocking eventfd: one thread signals it, another wakes on it (through its EventLoop, or
// poll) and drains it. The one way drivebusd's threads wake each other.
#pragma once

#include <string>

#include "sys/posix.hpp"

namespace drivebus::sys {

class EventFd {
public:
    // Made at start-up; `what` names it if the kernel refuses ("eventfd for the bus thread:
    // Too many open files", thrown as std::system_error).
    explicit EventFd(const std::string& what);

    [[nodiscard]] int fd() const noexcept { return fd_.get(); }
    // Wakes the reader. Never blocks (the descriptor is non-blocking) and fails only when the
    // counter is full, that is when it is signalled already: nothing to report.
    void signal() const noexcept;
    // Empties it; whether it had been signalled (it fails only when it was not).
    bool drain() const noexcept;

private:
    UniqueFd fd_;
};

}  // namespace drivebus::sys
