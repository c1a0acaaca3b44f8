// SPDX-License-Identifier: Apache-2.0
// reference(): the configuration's tables (keys.hpp) as text, section by section.
#include "config/reference.hpp"

#include "keys.hpp"

namespace drivebus::config {

namespace detail {

std::string range_text(const Range& range) {
    const auto lead = range.words.empty() ? std::string() : std::string(range.words) + " ";
    switch (range.form) {
    case Form::None: return "";
    case Form::Words: return std::string(range.words);
    case Form::Integers:
        return lead + std::to_string(range.lo) + (range.lo == range.hi ? "" : "-" + std::to_string(range.hi));
    case Form::Durations: {
        // Zero needs no unit: "0-10s".
        const auto text = [](Duration d) { return d == Duration{} ? std::string("0") : duration_text(d); };
        return lead + text(range.shortest) + "-" + text(range.longest);
    }
    case Form::Names: {
        std::string out;
        for (const auto name : range.names) {
            out.append(out.empty() ? "\"" : ", \"").append(name).append("\"");
        }
        return out;
    }
    }
    return "";
}

}  // namespace detail

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
