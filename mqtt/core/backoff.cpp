// SPDX-License-Identifier: Apache-2.0
#include "mqtt/backoff.hpp"

#include <algorithm>

namespace drivebus::mqtt {

Backoff::Duration Backoff::next(double random) noexcept {
    ++failures_;
    const auto base = current_;
    current_ = std::min(longest_, current_ * 2);
    const double cut = std::clamp(random, 0.0, 0.999999) / 2.0;
    return std::max(Duration(1), Duration(static_cast<Duration::rep>(static_cast<double>(base.count()) * (1.0 - cut))));
}

}  // namespace drivebus::mqtt
