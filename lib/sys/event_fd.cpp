// SPDX-License-Identifier: Apache-2.0
#include "sys/event_fd.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>
#include <system_error>

namespace drivebus::sys {

EventFd::EventFd(const std::string& what) {
    auto made = posix_call("eventfd", [] { return ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC); });
    if (!made) {
        throw std::system_error(made.error().error, std::generic_category(), what);
    }
    fd_.reset(*made);
}

void EventFd::signal() const noexcept {
    const std::uint64_t one = 1;
    (void)posix_call("write", [&] { return ::write(fd_.get(), &one, sizeof one); });
}

bool EventFd::drain() const noexcept {
    std::uint64_t count = 0;
    return posix_call("read", [&] { return ::read(fd_.get(), &count, sizeof count); }).has_value();
}

}  // namespace drivebus::sys
