// SPDX-License-Identifier: Apache-2.0
// How long a command may still act. A command can say when it stops being valid ("not_after",
// an absolute time), how old it may get ("max_age"), and when it was sent ("sent_at"); the
// bridge has a limit of its own (limits.max_command_age) that a command may shorten, not
// lengthen. Its age is the time since sent_at as the bridge's clock saw it arrive, plus the time
// it waited in the bridge; without sent_at, the wait alone (a lower bound). Pure: the times are
// arguments.
#pragma once

#include <chrono>
#include <expected>
#include <optional>
#include <string>
#include <string_view>

#include "mqtt/payload.hpp"

namespace drivebus::mqtt {

using WallTime = std::chrono::system_clock::time_point;

// A time as a command gives it: an integer (Unix time in milliseconds) or an RFC 3339 string
// with its offset ("2026-12-03T14:05:00Z", "2026-12-03T15:05:00.250+01:00").
[[nodiscard]] std::expected<WallTime, std::string> parse_time(const Json& value);

struct Freshness {
    std::optional<WallTime> not_after;
    std::optional<std::chrono::nanoseconds> max_age;
    std::optional<WallTime> sent_at;
};

struct Stale {
    std::string reason;  // "expired", or "clock_skew" (sent_at ahead of the bridge's clock by more than the limit)
    std::string message;
};

// The time left to `command` once it has waited `waited` in the bridge since it arrived at
// `received` (the bridge's wall clock then): nullopt when nothing limits it, else a positive
// duration; or why it must not act any more. `limit`: the bridge's max_command_age (zero: none).
[[nodiscard]] std::expected<std::optional<std::chrono::nanoseconds>, Stale> time_left(const Freshness& command,
                                                                                      WallTime received,
                                                                                      std::chrono::nanoseconds waited,
                                                                                      std::chrono::nanoseconds limit);

}  // namespace drivebus::mqtt
