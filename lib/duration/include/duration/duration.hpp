// SPDX-License-Identifier: Apache-2.0
// The one duration grammar of drivebus: the configuration file, drivebusctl's options and the
// simulator's all take a number and a unit, the number whole or with a fraction, no sign:
// "1500000ns", "250us", "100ms", "1.5s", "2min". A bare number is refused (is "30" seconds or
// milliseconds?), as is a sign, an exponent or hex. What range a value may take is the
// caller's business.
#pragma once

#include <chrono>
#include <expected>
#include <string>
#include <string_view>

namespace drivebus {

// The duration `text` stands for (surrounding blanks and blanks before the unit allowed),
// rounded to the nanosecond; else what is wrong with it, worded to follow the text itself:
// "has no unit: ...", "is not a duration: ...", "is too large".
[[nodiscard]] std::expected<std::chrono::nanoseconds, std::string> parse_duration(std::string_view text);

// The units, for messages: "ns, us, ms, s or min".
inline constexpr std::string_view kDurationUnits = "ns, us, ms, s or min";

}  // namespace drivebus
