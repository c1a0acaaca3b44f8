// SPDX-License-Identifier: Apache-2.0
// When a retained message (a drive's state, a bus's status) is published again. Pure: the value
// and the time are arguments; the relay (mqtt/relay.hpp) asks before each publication and
// says when the broker took one, tests drive it on a virtual clock (tests/mqtt/cadence_test.cpp).
//
// Due: the first time; after a change beyond the deadband (significant_change, payload.hpp);
// once `period` has passed since the last publication the broker took; when forced (the broker
// connected again: its retained copy may be gone) or marked again (what it says changed in a
// way the value cannot show, a bus's reason for being unreachable). A publication the broker
// did not take (not connected, too many unacknowledged) leaves it due: the next round tries it
// again, so a broker that stalls loses no change, only the ones in between.
#pragma once

#include <chrono>

#include "mqtt/payload.hpp"

namespace drivebus::mqtt {

class Cadence {
public:
    using Time = std::chrono::steady_clock::time_point;

    Cadence(std::chrono::nanoseconds period, double deadband) : period_(period), deadband_(deadband) {}

    [[nodiscard]] bool due(const Json& value, Time now, bool force) const;
    // Due by time alone (no value at hand yet): the first time, marked, or the period passed.
    [[nodiscard]] bool due_by_time(Time now) const noexcept { return pending_ || now - last_ >= period_; }
    // The broker took `value` at `now`.
    void published(Json value, Time now);
    void again() noexcept { pending_ = true; }
    // When it is due next without a change.
    [[nodiscard]] Time next() const noexcept { return last_ + period_; }

private:
    std::chrono::nanoseconds period_;
    double deadband_;
    Json last_value_;
    Time last_{};
    bool pending_ = true;
};

}  // namespace drivebus::mqtt
