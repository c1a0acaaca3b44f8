// SPDX-License-Identifier: Apache-2.0
#include "config/reload.hpp"

#include <algorithm>

namespace drivebus::config {
namespace {

const BusConfig* find(const Config& c, const std::string& name) {
    const auto it = std::ranges::find(c.buses, name, &BusConfig::name);
    return it == c.buses.end() ? nullptr : &*it;
}

std::string joined(const std::vector<std::string>& names) {
    std::string out;
    for (const auto& n : names) {
        out += (out.empty() ? "" : ", ") + n;
    }
    return out;
}

}  // namespace

std::expected<ReloadPlan, std::string> plan_reload(const Config& running, const Config& next) {
    if (running.ipc != next.ipc) {
        return std::unexpected(
            "[ipc] changed: it sets up and guards the shared memory once, at start; restart drivebusd to apply "
            "it (systemctl restart drivebusd, which ends every client's connection)");
    }
    ReloadPlan plan;
    plan.realtime_changed = running.realtime != next.realtime;
    for (const auto& bus : next.buses) {
        const auto* was = find(running, bus.name);
        if (was == nullptr) {
            plan.start.push_back(bus.name);
        } else if (plan.realtime_changed || was->settings != bus.settings) {
            plan.restart.push_back(bus.name);
        } else {
            plan.keep.push_back(bus.name);
        }
    }
    for (const auto& bus : running.buses) {
        if (find(next, bus.name) == nullptr) {
            plan.stop.push_back(bus.name);
        }
    }
    return plan;
}

std::string describe(const ReloadPlan& plan) {
    if (plan.nothing()) {
        return "no change";
    }
    std::string out;
    const auto part = [&](const std::vector<std::string>& names, const std::string& what) {
        if (!names.empty()) {
            out += (out.empty() ? "" : "; ") + what + " " + joined(names);
        }
    };
    part(plan.keep, "kept");
    part(plan.restart, plan.realtime_changed ? "restarted ([realtime] changed)" : "restarted (settings changed)");
    part(plan.stop, "stopped");
    part(plan.start, "started");
    return out;
}

}  // namespace drivebus::config
