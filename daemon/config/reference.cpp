// SPDX-License-Identifier: Apache-2.0
// reference(): the configuration's tables (settings/keys.hpp) as text, section by section.
#include "config/reference.hpp"

#include "read.hpp"

namespace drivebus::config {

std::vector<SectionReference> reference() {
    auto sections = detail::top_reference();
    for (auto& section : detail::bus_reference()) {
        sections.push_back(std::move(section));
    }
    sections.push_back(detail::drive_reference());
    sections.push_back(detail::poll_reference());
    return sections;
}

}  // namespace drivebus::config
