// SPDX-License-Identifier: Apache-2.0
#include "sys/posix.hpp"

#include <unistd.h>

#include <cstring>

namespace drivebus::sys {

std::string SysError::message() const {
    return std::string(call) + ": " + std::strerror(error);
}

void UniqueFd::reset(int fd) noexcept {
    if (fd_ >= 0) {
        // close() must not be retried on EINTR on Linux: the descriptor is gone either way.
        ::close(fd_);
    }
    fd_ = fd;
}

rtu::Instant now() noexcept {
    return rtu::Clock::now();
}

timespec to_timespec(rtu::Duration d) noexcept {
    const auto ns = d.count();
    return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

timespec to_timespec(rtu::Instant t) noexcept {
    return to_timespec(t.time_since_epoch());
}

}  // namespace drivebus::sys
