// SPDX-License-Identifier: Apache-2.0
// What a reload (SIGHUP) does with a new configuration, decided without doing it: which buses
// keep running untouched, which are restarted with their new settings, which stop and which
// start. Pure: tested without a bus or RouDi.
#pragma once

#include <expected>
#include <string>
#include <vector>

#include "config/config.hpp"

namespace drivebus::config {

struct ReloadPlan {
    std::vector<std::string> keep;     // same settings: untouched, their clients see nothing
    std::vector<std::string> restart;  // settings changed: restarted, leases carried over
    std::vector<std::string> stop;     // no longer configured
    std::vector<std::string> start;    // new
    bool realtime_changed = false;     // every bus restarts to take [realtime]

    [[nodiscard]] bool nothing() const noexcept { return restart.empty() && stop.empty() && start.empty(); }
};

// The plan from `running` to `next`, or why `next` cannot be applied without a restart of
// drivebusd (one line): [ipc] sizes and guards the shared memory, which is set up once.
[[nodiscard]] std::expected<ReloadPlan, std::string> plan_reload(const Config& running, const Config& next);

// "kept line1; restarted line2 (settings changed); stopped line3; started line4", or "no change".
[[nodiscard]] std::string describe(const ReloadPlan& plan);

}  // namespace drivebus::config
