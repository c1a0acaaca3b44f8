// SPDX-License-Identifier: Apache-2.0
#include "ipc/lease_record.hpp"

#include <charconv>

#include <fmt/format.h>

namespace drivebus::ipc {
namespace {

constexpr std::string_view kHeader = "drivebus-leases 1";

// A holder's name is the client's own word: one line of printable characters in the file.
std::string one_line(std::string_view text) {
    std::string out;
    for (const char c : text) {
        out += static_cast<unsigned char>(c) < 0x20 || c == 0x7F ? '?' : c;
    }
    return out;
}

std::optional<config::LeaseFallback> fallback_named(std::string_view name) {
    for (const auto f : {config::LeaseFallback::Hold, config::LeaseFallback::Stop, config::LeaseFallback::Freewheel}) {
        if (config::to_string(f) == name) {
            return f;
        }
    }
    return std::nullopt;
}

// The next field of `line` up to a space; `line` moves past it and the space.
std::string_view next_field(std::string_view& line) {
    const auto end = line.find(' ');
    const auto field = line.substr(0, end);
    line = end == std::string_view::npos ? std::string_view{} : line.substr(end + 1);
    return field;
}

}  // namespace

std::string format_lease_record(const std::vector<RecordedLease>& leases) {
    std::string out(kHeader);
    out += '\n';
    for (const auto& l : leases) {
        out += fmt::format("{} {} {} {} {}\n", l.unconfirmed ? "unconfirmed" : "lease", l.drive, l.address.value_or(0),
                           l.fallback ? config::to_string(*l.fallback) : std::string_view("?"), one_line(l.holder));
    }
    return out;
}

ReadLeaseRecord parse_lease_record(std::string_view text) {
    ReadLeaseRecord out;
    std::size_t number = 0;
    while (!text.empty()) {
        const auto end = text.find('\n');
        std::string_view line = text.substr(0, end);
        text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
        ++number;
        if (number == 1) {
            if (line != kHeader) {
                out.problems.push_back(fmt::format("line 1 is not \"{}\"", kHeader));
            } else {
                continue;
            }
        }
        if (line.empty()) {
            continue;
        }
        const auto kind = next_field(line);
        if (kind != "lease" && kind != "unconfirmed") {
            if (number != 1) {
                out.problems.push_back(fmt::format("line {} is not a lease", number));
            }
            continue;
        }
        RecordedLease l;
        l.unconfirmed = kind == "unconfirmed";
        l.drive = std::string(next_field(line));
        if (l.drive.empty()) {
            out.problems.push_back(fmt::format("line {} names no drive", number));
            continue;
        }
        const auto address = next_field(line);
        int value = 0;
        if (const auto [p, ec] = std::from_chars(address.data(), address.data() + address.size(), value);
            ec == std::errc{} && p == address.data() + address.size() && value >= 1 && value <= 247) {
            l.address = value;
        }
        l.fallback = fallback_named(next_field(line));
        l.holder = std::string(line);
        if (!l.address || !l.fallback) {
            out.problems.push_back(fmt::format("line {} (drive {}) is damaged", number, l.drive));
        }
        out.leases.push_back(std::move(l));
    }
    if (number == 0) {
        out.problems.emplace_back("it is empty");
    }
    return out;
}

}  // namespace drivebus::ipc
