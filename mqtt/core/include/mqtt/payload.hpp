// SPDX-License-Identifier: Apache-2.0
// The JSON the bridge publishes (schemas in docs/mqtt.md), built from drivebusd's snapshots
// and the drives' profiles, and the deadband rule that decides whether a new state is worth a
// message before the period says so.
#pragma once

#include <nlohmann/json.hpp>
#include <string_view>

#include "drivebus/profile.hpp"
#include "drivebus/shm.hpp"

namespace drivebus::mqtt {

using Json = nlohmann::json;

// A drive's state: identity, health, each polled register (profile name, engineering value,
// unit, raw word; value null when not valid), the Altivar decoding when the profile has a
// [control] section, and the control lease. `profile` may be null (registers by number).
// `polled_ns`: the end of the newest reply the values came from, on the board's
// CLOCK_MONOTONIC (for latency measurements on the board; it means nothing elsewhere).
[[nodiscard]] Json drive_state(const shm::DriveSnapshot& snapshot, const Profile* profile);

// The bus status: line, drives, counters, and whether drivebusd is heard from.
[[nodiscard]] Json bus_status(const shm::BusStatus& status, bool daemon_alive);
// The bus status while the bridge cannot reach drivebusd at all.
[[nodiscard]] Json bus_unreachable(std::string_view bus, std::string_view why);

// Whether `now` differs from `published` enough to publish before the period: any field
// other than a register's value differs, or a value moved by more than `deadband`
// (engineering units); counters and sequence numbers never count.
[[nodiscard]] bool significant_change(const Json& published, const Json& now, double deadband);

}  // namespace drivebus::mqtt
