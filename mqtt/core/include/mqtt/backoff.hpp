// SPDX-License-Identifier: Apache-2.0
// Reconnection delays: doubling from `shortest` up to `longest`, each spread down to half by a
// random fraction the caller draws (so that a plant's boards do not all reconnect at once after
// a broker restart), back to `shortest` after a success.
#pragma once

#include <chrono>
#include <cstdint>

namespace drivebus::mqtt {

class Backoff {
public:
    using Duration = std::chrono::nanoseconds;
    Backoff(Duration shortest, Duration longest) : shortest_(shortest), longest_(longest), current_(shortest) {}

    // The delay before the next attempt; `random` in [0, 1) takes up to half of it off.
    [[nodiscard]] Duration next(double random = 0.0) noexcept;
    void reset() noexcept {
        current_ = shortest_;
        failures_ = 0;
    }
    // Attempts failed since the last reset().
    [[nodiscard]] std::uint64_t failures() const noexcept { return failures_; }

private:
    Duration shortest_;
    Duration longest_;
    Duration current_;
    std::uint64_t failures_ = 0;
};

}  // namespace drivebus::mqtt
