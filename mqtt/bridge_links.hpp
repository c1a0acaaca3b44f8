// SPDX-License-Identifier: Apache-2.0
// What the bridge keeps per bus and per drive (bridge.cpp connects and publishes them,
// bridge_commands.cpp carries out the Commander's steps on them). The loop's thread alone reads
// and changes them.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <vector>

#include "bridge.hpp"
#include "mqtt/backoff.hpp"
#include "mqtt/cadence.hpp"

namespace drivebus::mqtt {

// How soon a bus drivebusd does not answer is tried again: from 1 s, doubling up to 30 s.
inline constexpr auto kBusRetryShortest = std::chrono::seconds(1);
inline constexpr auto kBusRetryLongest = std::chrono::seconds(30);

struct Bridge::DriveLink {
    DriveSettings settings;
    Drive drive;
    Subscription subscription;
    // The newest snapshot, from dispatch() on the bridge's loop; `fresh` until its state has been
    // published or found not due.
    std::optional<shm::DriveSnapshot> latest;
    bool fresh = false;
    Cadence cadence{settings.period, settings.deadband};
};

struct Bridge::BusLink {
    BusSettings settings;
    std::optional<Bus> bus;
    std::vector<std::shared_ptr<DriveLink>> drives;  // set once connected
    Backoff retry{kBusRetryShortest, kBusRetryLongest};
    Clock::time_point next_attempt{};
    std::string last_error;
    Cadence cadence{settings.period, 0.0};  // set again once `settings` is
};

}  // namespace drivebus::mqtt
