// SPDX-License-Identifier: Apache-2.0
// One bus as drivebusd runs it (its settings, its bus thread, its ipc thread), started and
// stopped: for a reload that restarts it (its leases carried over), or for good (drivebusd
// stops, a reload drops it), when every lease held first gets its drive's fallback.
#pragma once

#include <expected>
#include <memory>
#include <string>
#include <vector>

#include "bus/bus_loop.hpp"
#include "config/config.hpp"
#include "ipc/bus_service.hpp"
#include "rt/kernel_facts.hpp"

namespace drivebus::daemon {

struct RunningBus {
    std::unique_ptr<config::BusConfig> config;
    std::unique_ptr<bus::BusLoop> loop;
    std::unique_ptr<ipc::BusService> service;
};

// Starts one bus: its thread, then its ipc thread (with the leases a reload carried over; with
// none, the fallbacks of the leases the last drivebusd held go out first).
[[nodiscard]] std::expected<RunningBus, std::string> start_bus(const config::BusConfig& settings,
                                                               const config::RealtimeConfig& rt,
                                                               const ipc::Layout& layout, const rt::KernelFacts& kernel,
                                                               const ipc::Carried& carried);

// Stops one bus for a restart: what it carries over to the restarted bus.
[[nodiscard]] ipc::Carried restart_bus(RunningBus& b);

// Stops buses for good: each writes the fallback of every lease held and waits (bounded) for
// the drive's answer before it lets its line go. The buses wind down together.
void end_buses(std::vector<RunningBus>& buses);

}  // namespace drivebus::daemon
