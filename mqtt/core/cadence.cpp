// SPDX-License-Identifier: Apache-2.0
#include "mqtt/cadence.hpp"

#include <utility>

namespace drivebus::mqtt {

bool Cadence::due(const Json& value, Time now, bool force) const {
    return force || due_by_time(now) || significant_change(last_value_, value, deadband_);
}

void Cadence::published(Json value, Time now) {
    last_value_ = std::move(value);
    last_ = now;
    pending_ = false;
}

}  // namespace drivebus::mqtt
