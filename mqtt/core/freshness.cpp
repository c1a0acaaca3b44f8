// SPDX-License-Identifier: Apache-2.0
#include "mqtt/freshness.hpp"

#include <algorithm>
#include <charconv>

namespace drivebus::mqtt {
namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;

// Digits at text[at, at + n) as a number, or -1.
int digits(std::string_view text, std::size_t at, std::size_t n) {
    if (at + n > text.size()) {
        return -1;
    }
    int value = 0;
    const auto* first = text.data() + at;
    const auto [ptr, ec] = std::from_chars(first, first + n, value);
    return ec == std::errc() && ptr == first + n ? value : -1;
}

std::expected<WallTime, std::string> parse_rfc3339(std::string_view text) {
    const auto bad = [&] {
        return std::unexpected("'" + std::string(text.substr(0, 40)) +
                               "' is not an RFC 3339 time with an offset (2026-12-03T14:05:00Z)");
    };
    if (text.size() < 20 || text[4] != '-' || text[7] != '-' || (text[10] != 'T' && text[10] != 't') ||
        text[13] != ':' || text[16] != ':') {
        return bad();
    }
    const int y = digits(text, 0, 4);
    const int mo = digits(text, 5, 2);
    const int d = digits(text, 8, 2);
    const int h = digits(text, 11, 2);
    const int mi = digits(text, 14, 2);
    const int s = digits(text, 17, 2);
    const std::chrono::year_month_day date{std::chrono::year(y), std::chrono::month(static_cast<unsigned>(mo)),
                                           std::chrono::day(static_cast<unsigned>(d))};
    if (y < 0 || mo < 0 || d < 0 || !date.ok() || h < 0 || h > 23 || mi < 0 || mi > 59 || s < 0 || s > 60) {
        return bad();
    }
    std::size_t at = 19;
    nanoseconds fraction{0};
    if (at < text.size() && text[at] == '.') {
        ++at;
        std::int64_t scale = 100'000'000;
        const std::size_t start = at;
        for (; at < text.size() && text[at] >= '0' && text[at] <= '9'; ++at) {
            fraction += nanoseconds((text[at] - '0') * scale);
            scale /= 10;
        }
        if (at == start) {
            return bad();
        }
    }
    std::chrono::minutes offset{0};
    const std::string_view zone = text.substr(at);
    if (zone == "Z" || zone == "z") {
        // UTC
    } else if (zone.size() == 6 && (zone[0] == '+' || zone[0] == '-') && zone[3] == ':') {
        const int oh = digits(zone, 1, 2);
        const int om = digits(zone, 4, 2);
        if (oh < 0 || oh > 23 || om < 0 || om > 59) {
            return bad();
        }
        offset = std::chrono::hours(oh) + std::chrono::minutes(om);
        if (zone[0] == '-') {
            offset = -offset;
        }
    } else {
        return bad();
    }
    // A leap second (:60) is taken as the next second: the limits here are far coarser.
    return WallTime(std::chrono::sys_days(date).time_since_epoch()) + std::chrono::hours(h) + std::chrono::minutes(mi) +
           std::chrono::seconds(s) + std::chrono::duration_cast<WallTime::duration>(fraction) - offset;
}

std::string in_ms(nanoseconds d) {
    return std::to_string(std::chrono::duration_cast<milliseconds>(d).count()) + " ms";
}

}  // namespace

std::expected<WallTime, std::string> parse_time(const Json& value) {
    if (value.is_number_integer()) {
        const auto ms = value.get<std::int64_t>();
        // Unix milliseconds from 2000 to 2200: a number of seconds given by mistake is refused.
        if (ms < 946'684'800'000 || ms > 7'258'118'400'000) {
            return std::unexpected(std::to_string(ms) + " is not a time in Unix milliseconds (2000-2200)");
        }
        return WallTime(milliseconds(ms));
    }
    if (value.is_string()) {
        return parse_rfc3339(value.get_ref<const std::string&>());
    }
    return std::unexpected(std::string("a time: Unix milliseconds or an RFC 3339 string"));
}

std::expected<std::optional<nanoseconds>, Stale> time_left(const Freshness& command, WallTime received,
                                                           nanoseconds waited, nanoseconds limit) {
    std::optional<nanoseconds> left;
    const bool own_limit = command.max_age && (limit <= nanoseconds::zero() || *command.max_age < limit);
    if (own_limit) {
        limit = *command.max_age;
    }
    if (limit > nanoseconds::zero()) {
        nanoseconds age = waited;
        if (command.sent_at) {
            const nanoseconds transit = received - *command.sent_at;
            if (-transit > limit) {
                return std::unexpected(Stale{"clock_skew", "sent_at is " + in_ms(-transit) +
                                                               " ahead of the bridge's clock, more than the limit of " +
                                                               in_ms(limit) + ": are both clocks synchronised?"});
            }
            age += std::max(transit, nanoseconds::zero());
        }
        if (age >= limit) {
            return std::unexpected(Stale{"expired", "the command is " + in_ms(age) + " old, older than " +
                                                        (own_limit ? "its max_age" : "the bridge's max_command_age") +
                                                        " of " + in_ms(limit)});
        }
        left = limit - age;
    }
    if (command.not_after) {
        const nanoseconds until = *command.not_after - (received + waited);
        if (until <= nanoseconds::zero()) {
            return std::unexpected(Stale{"expired", "the command is " + in_ms(-until) + " past its not_after"});
        }
        left = left ? std::min(*left, until) : until;
    }
    return left;
}

}  // namespace drivebus::mqtt
