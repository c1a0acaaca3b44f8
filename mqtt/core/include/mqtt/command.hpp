// SPDX-License-Identifier: Apache-2.0
// Commands on drivebus/<node>/<bus>/<drive>/set, checked before anything reaches drivebusd:
//
//   {"id": "c-17", "registers": {"FA01": 40.0, "FA00": {"raw": 50176}}}
//   {"id": 18, "frequency": 40.0, "verb": "run"}
//   {"id": "hb-1", "verb": "heartbeat"}
//   {"id": 19, "verb": "run", "sent_at": "2026-12-03T14:05:00.120Z", "max_age": "2s"}
//
// Register values are engineering values (the profile's unit and scale) or {"raw": word}.
// The result, on .../result, echoes the id (docs/mqtt.md). not_after, max_age and sent_at limit
// how late a command may act (mqtt/freshness.hpp).
#pragma once

#include <cstdint>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "drivebus/profile.hpp"
#include "mqtt/freshness.hpp"
#include "mqtt/payload.hpp"

namespace drivebus::mqtt {

enum class Verb : std::uint8_t { None, Run, RunReverse, Stop, Freewheel, ResetFault, Heartbeat, Release };

struct RegisterValue {
    std::string name;
    std::optional<double> value;      // engineering
    std::optional<std::int64_t> raw;  // the word itself
};

struct Command {
    Json id;  // as the sender gave it: a string or a number
    std::vector<RegisterValue> registers;
    std::optional<double> frequency;
    Verb verb = Verb::None;
    Freshness freshness;
};

struct CommandError {
    Json id;  // null when the payload did not give one
    std::string message;
};

// Parses a command payload; refuses one larger than `max_payload` without parsing it.
[[nodiscard]] std::expected<Command, CommandError> parse_command(std::string_view payload, std::size_t max_payload);

// What a command comes to on the drive, in order: register writes (the named registers in name
// order, then the frequency reference, then the verb's command word), then the lease renewal
// or release.
struct Action {
    enum class Kind : std::uint8_t { Write, KeepAlive, Release };
    Kind kind = Kind::Write;
    std::uint16_t address = 0;
    std::uint16_t raw = 0;
    std::string name;  // the register, for the result
};

// The actions of `command` on a drive with `profile` (null: registers by number, raw values
// only), or one line saying what is wrong (unknown register, read-only, out of range, a verb
// the profile has no word for).
[[nodiscard]] std::expected<std::vector<Action>, std::string> plan(const Command& command, const Profile* profile);

[[nodiscard]] std::string_view to_string(Verb verb) noexcept;

// Results: {"id": ..., "ok": true, ...} / {"id": ..., "ok": false, "error": "...", "reason": "..."}.
[[nodiscard]] Json result_ok(const Json& id);
[[nodiscard]] Json result_error(const Json& id, std::string_view reason, std::string_view message);

}  // namespace drivebus::mqtt
