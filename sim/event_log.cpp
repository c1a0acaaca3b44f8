// SPDX-License-Identifier: Apache-2.0
#include "event_log.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace drivebus::sim {

EventLog::EventLog(const std::string& path) {
    if (path.empty()) {
        return;
    }
    file_.reset(std::fopen(path.c_str(), "w"));
    if (!file_) {
        throw std::runtime_error(path + ": " + std::strerror(errno));
    }
    buffer_.resize(std::size_t{1} << 20);
    std::setvbuf(file_.get(), buffer_.data(), _IOFBF, buffer_.size());
}

void EventLog::record(rtu::Instant at, std::uint8_t address, std::uint8_t function) {
    if (!file_) {
        return;
    }
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(at.time_since_epoch()).count();
    std::fprintf(file_.get(), "%lld %u %u\n", static_cast<long long>(ns), static_cast<unsigned>(address),
                 static_cast<unsigned>(function));
}

}  // namespace drivebus::sim
