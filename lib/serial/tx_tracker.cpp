// SPDX-License-Identifier: Apache-2.0
#include "serial/tx_tracker.hpp"

#include <algorithm>

namespace drivebus::serial {

TransmitTracker::TransmitTracker(rtu::CharacterTiming timing, UartControl& uart, int fd) noexcept
    : timing_(timing), uart_(&uart), fd_(fd) {}

void TransmitTracker::started(rtu::Instant written, std::size_t bytes) noexcept {
    // Bytes written while earlier ones are still on the wire go out after them.
    const rtu::Instant begin = std::max(written, computed_end_);
    computed_end_ = begin + rtu::wire_time(timing_, bytes);
    next_check_ = computed_end_;
    cap_ = written + 2 * (computed_end_ - written) + kCapSlack;
    busy_ = true;
}

std::optional<rtu::Instant> TransmitTracker::check(rtu::Instant now) {
    if (!busy_) {
        return last_done_;
    }
    if (now < next_check_) {
        return std::nullopt;
    }
    auto finish = [&](rtu::Instant at) {
        busy_ = false;
        polled_ = false;
        last_done_ = at;
        return at;
    };
    if (lsr_supported_) {
        const auto empty = uart_->transmitter_empty(fd_);
        if (!empty) {
            lsr_supported_ = false;  // the driver cannot tell: it will not learn to
            if (polled_) {
                // It said "not empty" earlier in this transmission: the computed end has
                // already proved short, so now is the best bound left.
                return finish(now);
            }
        } else if (*empty) {
            return finish(now);
        } else if (now >= cap_) {
            ++gave_up_;
            return finish(now);
        } else {
            // Still shifting out (the computed time is a little short, or the UART started
            // late): look again a quarter character later, never past the cap.
            polled_ = true;
            next_check_ = std::min(now + timing_.character / 4, cap_);
            return std::nullopt;
        }
    }
    // now >= next_check_ >= computed_end_: the last stop bit has left by the computation.
    return finish(computed_end_);
}

}  // namespace drivebus::serial
