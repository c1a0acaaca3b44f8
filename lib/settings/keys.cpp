// SPDX-License-Identifier: Apache-2.0
// Durations, choices and ranges as every file reads and states them.
#include "settings/keys.hpp"

#include <algorithm>
#include <array>
#include <cstdint>

#include "duration/duration.hpp"

namespace drivebus::settings {
namespace {

struct Unit {
    std::string_view suffix;
    std::int64_t nanoseconds;
};

// Largest first, for duration_text().
constexpr std::array<Unit, 4> kUnits = {{{"s", 1'000'000'000}, {"ms", 1'000'000}, {"us", 1'000}, {"ns", 1}}};

}  // namespace

std::string listed(std::span<const std::string_view> names) {
    std::string out;
    for (const auto name : names) {
        out.append(out.empty() ? "" : ", ").append(name);
    }
    return out;
}

std::string duration_text(Duration duration) {
    const auto ns = duration.count();
    for (const auto& unit : kUnits) {
        if (ns % unit.nanoseconds == 0) {
            return std::to_string(ns / unit.nanoseconds) + std::string(unit.suffix);
        }
    }
    return std::to_string(ns) + "ns";
}

std::optional<Duration> checked_duration(Section& s, std::string_view key, std::string_view text, Duration lo,
                                         Duration hi) {
    const auto value = parse_duration(text);
    if (!value) {
        s.fail(std::string(key) + " " + in_quotes(text) + " " + value.error());
        return std::nullopt;
    }
    if (*value < lo || *value > hi) {
        const bool below = *value < lo;
        s.fail(std::string(key) + " " + std::string(text) + (below ? " is below " : " is above ") +
               duration_text(below ? lo : hi));
        return std::nullopt;
    }
    return *value;
}

std::optional<Duration> duration(Section& s, const toml::table& table, std::string_view key, Duration lo, Duration hi,
                                 Need need) {
    // A bare number has no unit: say so rather than only "must be a string".
    if (const auto* node = table.get(key); node != nullptr && (node->is_integer() || node->is_floating_point())) {
        s.fail(std::string(key) + " must be a string with a unit, e.g. \"100ms\", not a bare number");
        return std::nullopt;
    }
    const auto text = s.string(key, need);
    if (!text) {
        return std::nullopt;
    }
    return checked_duration(s, key, *text, lo, hi);
}

std::optional<std::size_t> choice(Section& s, std::string_view key, std::span<const std::string_view> names) {
    const auto text = s.string(key);
    if (!text) {
        return std::nullopt;
    }
    const auto it = std::ranges::find(names, *text);
    if (it == names.end()) {
        s.fail(std::string(key) + " " + in_quotes(*text) + " is not one of " + listed(names));
        return std::nullopt;
    }
    return static_cast<std::size_t>(it - names.begin());
}

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

}  // namespace drivebus::settings
