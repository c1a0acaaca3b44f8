// SPDX-License-Identifier: Apache-2.0
// What the views of drivebusctl share: times in milliseconds, joins, a register's profile
// entry, the line in one phrase. Internal to drivebusctl_core.
#pragma once

#include <fmt/format.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "drivebus/profile.hpp"
#include "drivebus/shm.hpp"

namespace drivebus::ctl::detail {

inline std::string ms_text(std::int64_t ns) {
    return fmt::format("{:.2f} ms", static_cast<double>(ns) / 1e6);
}

inline double ms_value(std::int64_t ns) {
    return static_cast<double>(ns / 1000) / 1000.0;  // whole microseconds
}

inline std::string join(const std::vector<std::string>& items, std::string_view separator) {
    std::string out;
    for (const auto& item : items) {
        out += (out.empty() ? "" : std::string(separator)) + item;
    }
    return out;
}

inline const RegisterInfo* info_of(const Profile* profile, std::uint16_t address) {
    return profile != nullptr ? profile->find(address) : nullptr;
}

inline std::string line_text(const shm::BusStatus& s) {
    return fmt::format("{}, {} {}{}", shm::view(s.device), s.baud, shm::view(s.format), s.up != 0 ? "" : " (down)");
}

}  // namespace drivebus::ctl::detail
