// SPDX-License-Identifier: Apache-2.0
#include "duration/duration.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace drivebus {
namespace {

struct Unit {
    std::string_view suffix;
    std::int64_t nanoseconds;
};
constexpr std::array<Unit, 5> kUnits = {
    {{"ns", 1}, {"us", 1'000}, {"ms", 1'000'000}, {"s", 1'000'000'000}, {"min", 60'000'000'000}}};

bool digit(char c) {
    return c >= '0' && c <= '9';
}

std::string_view trim(std::string_view text) {
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) {
        text.remove_prefix(1);
    }
    while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) {
        text.remove_suffix(1);
    }
    return text;
}

}  // namespace

std::expected<std::chrono::nanoseconds, std::string> parse_duration(std::string_view text) {
    const std::string not_one =
        "is not a duration: a number and a unit (" + std::string(kDurationUnits) + "), e.g. '100ms' or '1.5s'";
    text = trim(text);
    // The number: digits, then optionally '.' and digits.
    std::size_t i = 0;
    std::int64_t whole = 0;
    bool overflow = false;
    while (i < text.size() && digit(text[i])) {
        const int d = text[i] - '0';
        overflow = overflow || whole > (std::numeric_limits<std::int64_t>::max() - d) / 10;
        if (!overflow) {
            whole = whole * 10 + d;
        }
        ++i;
    }
    const std::size_t whole_digits = i;
    double fraction = 0.0;
    std::size_t fraction_digits = 0;
    if (i < text.size() && text[i] == '.') {
        ++i;
        double scale = 0.1;
        while (i < text.size() && digit(text[i])) {
            fraction += (text[i] - '0') * scale;
            scale /= 10.0;
            ++fraction_digits;
            ++i;
        }
        if (fraction_digits == 0) {
            return std::unexpected(not_one);
        }
    }
    if (whole_digits == 0) {
        return std::unexpected(not_one);
    }
    const std::string_view unit_text = trim(text.substr(i));
    if (unit_text.empty()) {
        return std::unexpected("has no unit: write " + std::string(kDurationUnits) + " after the number, e.g. '100ms'");
    }
    const Unit* unit = nullptr;
    for (const Unit& u : kUnits) {
        if (u.suffix == unit_text) {
            unit = &u;
        }
    }
    if (unit == nullptr) {
        return std::unexpected(not_one);
    }
    const auto part = static_cast<std::int64_t>(std::llround(fraction * static_cast<double>(unit->nanoseconds)));
    if (overflow || whole > (std::numeric_limits<std::int64_t>::max() - part) / unit->nanoseconds) {
        return std::unexpected("is too large");
    }
    return std::chrono::nanoseconds(whole * unit->nanoseconds + part);
}

}  // namespace drivebus
