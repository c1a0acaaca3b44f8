// SPDX-License-Identifier: Apache-2.0
// What the configured polling asks of the line, against what the line can carry. Pure.
//
// Every read is a request (8 bytes), a silence of t3.5, the reply (5 + 2 per register) and a
// silence of t3.5 before the next request: that is the least line time it takes, before the
// drive's own response time. A poll group whose reads take longer than its period cannot be
// read every period, and poll groups whose shares of the line add up to more than all of it
// cannot all be read as often as configured. Neither is an error (the scheduler reads each
// group as often as the line allows), but the configured periods are then a promise the line
// cannot keep: drivebusd says so at start-up and in --check-config.
#pragma once

#include <string>
#include <vector>

#include "master/bus_plan.hpp"
#include "rtu/timing.hpp"

namespace drivebus::master {

// The least line time one cycle of `group` on `drive` takes (all its reads).
[[nodiscard]] rtu::Duration poll_line_time(const DrivePlan& drive, const PollGroup& group,
                                           const rtu::CharacterTiming& timing);

// One line per poll group that cannot fit its period, and one per bus whose poll groups need
// more than the whole line.
[[nodiscard]] std::vector<std::string> line_budget_warnings(const BusPlan& bus);

}  // namespace drivebus::master
