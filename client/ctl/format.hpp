// SPDX-License-Identifier: Apache-2.0
// drivebusctl's pure helpers: exit codes, durations, register values with units and scale.
// Nothing here talks to drivebusd; tests/ctl/format_test.cpp covers it.
#pragma once

#include <chrono>
#include <cstdint>
#include <expected>
#include <string>
#include <string_view>
#include <vector>

#include "drivebus/client.hpp"

namespace drivebus::ctl {

// drivebusctl's exit status (docs/drivebusctl.md).
inline constexpr int kExitOk = 0;
inline constexpr int kExitDrive = 1;         // exception, timeout, bad frame
inline constexpr int kExitUsage = 2;         // bad arguments
inline constexpr int kExitRejected = 3;      // drivebusd's validation, unsupported
inline constexpr int kExitNotPermitted = 4;  // lease held by another client, not in the group
inline constexpr int kExitUnavailable = 5;   // no drivebusd, no such bus, bus down, no reply
inline constexpr int kExitQueueFull = 6;
inline constexpr int kExitWithdrawn = 7;  // not answered in time, withdrawn: never sent
inline constexpr int kExitUnknown = 8;    // not answered in time, already sent: outcome unknown
inline constexpr int kExitExpired = 9;    // not on the wire by its --deadline: dropped, never sent

[[nodiscard]] int exit_code(ErrorKind kind) noexcept;
// The kind as JSON names it: "not_permitted".
[[nodiscard]] std::string kind_name(ErrorKind kind);

// What to do about a rejection by drivebusd, from the drive's profile: "F803 takes 0..100 (0-100 s)".
// `what` is "read", "write" or "identify"; `start` the first of `count` registers. Empty when
// there is nothing to add.
[[nodiscard]] std::string rejection_hint(const Error& error, const Profile* profile, std::string_view what,
                                         std::uint16_t start, std::size_t count);

// A DURATION option: drivebus's one grammar (lib/duration: "500ms", "2s", "1.5s", "2min",
// "250us"), rounded up to whole milliseconds, from 1ms to 24h.
[[nodiscard]] std::expected<std::chrono::milliseconds, std::string> option_duration(std::string_view text);
// An age or a span for people: "35 ms", "1.2 s", "3 min", "2 h".
[[nodiscard]] std::string format_age(std::int64_t ns);

// "0xFD00".
[[nodiscard]] std::string hex(std::uint16_t value);
// Decimal places a scale shows: 0.01 -> 2, 0.1 -> 1, 1 -> 0, 0.5 -> 1.
[[nodiscard]] int decimals(double scale) noexcept;
// The engineering value, rounded to the scale's decimals (30.0 for raw 3000 at 0.01).
[[nodiscard]] double engineering(const RegisterInfo& info, std::uint16_t raw) noexcept;
// Whether a register's engineering value says more than its raw value (a unit, a scale, a sign).
[[nodiscard]] bool has_engineering(const RegisterInfo& info) noexcept;
// "30.00 Hz", "-5", "12.5 %"; empty when the register has no unit, scale or sign.
[[nodiscard]] std::string format_engineering(const RegisterInfo& info, std::uint16_t raw);
// The meanings of the bits set in `raw`, short (up to a colon): "10 Run/stop".
[[nodiscard]] std::vector<std::string> set_bits(const RegisterInfo& info, std::uint16_t raw);
// The enumerated meaning of `raw`, if the profile gives one.
[[nodiscard]] std::string value_meaning(const RegisterInfo& info, std::uint16_t raw);

// One register as drivebusctl read prints it: name (or "-"), hex address, raw, engineering
// value with unit (or empty), title.
[[nodiscard]] std::vector<std::string> register_columns(std::uint16_t address, std::uint16_t raw,
                                                        const RegisterInfo* info);

// A value for register `info` (null: raw only): raw decimal or 0x hex, negative when the
// register is signed, or a number with the register's unit ("30Hz", "30.5 Hz"), converted
// through its scale. Only the syntax and 16 bits are checked here: drivebusd checks the range.
[[nodiscard]] std::expected<std::uint16_t, std::string> parse_value(std::string_view text, const RegisterInfo* info);
// Joins a unit given as its own argument to the number before it: {"30.5", "Hz"} -> {"30.5 Hz"}.
[[nodiscard]] std::vector<std::string> join_units(const std::vector<std::string>& args);

}  // namespace drivebus::ctl
