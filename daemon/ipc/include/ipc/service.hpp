// SPDX-License-Identifier: Apache-2.0
// iceoryx service descriptions of a bus: ("drivebus", <bus>, <event>).
#pragma once

#include <string>
#include <string_view>

#include "drivebus/shm.hpp"
#include "iceoryx_posh/capro/service_description.hpp"

namespace drivebus::ipc {

inline iox::capro::IdString_t id(std::string_view text) {
    return {iox::cxx::TruncateToCapacity, std::string(text).c_str()};
}

inline iox::capro::ServiceDescription service(const std::string& bus, std::string_view event) {
    return {id(shm::kService), id(bus), id(event)};
}

}  // namespace drivebus::ipc
