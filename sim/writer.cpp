// SPDX-License-Identifier: Apache-2.0
#include "writer.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>

namespace drivebus::sim {

PacedWriter::PacedWriter(int fd, rtu::Duration spin, rtu::Duration slip) : fd_(fd), spin_(spin), slip_(slip) {}

void PacedWriter::enqueue(const TxPlan& plan) {
    for (const TxByte& b : plan) {
        const auto pos = std::upper_bound(queue_.begin(), queue_.end(), b.at,
                                          [](rtu::Instant t, const TxByte& q) { return t < q.at; });
        queue_.insert(pos, b);
    }
    service();
}

void PacedWriter::service() {
    timer_.acknowledge();
    while (!queue_.empty()) {
        rtu::Instant now = sys::now();
        const rtu::Duration wait = queue_.front().at - now;
        // A timer that cannot be armed leaves the wait to the spin below: late, never lost.
        if (wait > spin_ && timer_.arm(queue_.front().at - spin_)) {
            return;
        }
        while (now < queue_.front().at) {
            now = sys::now();
        }
        if (now - queue_.front().at > slip_) {
            slipped_ = true;
            ++slips_;
        }
        std::array<std::uint8_t, 256> burst{};
        std::size_t n = 0;
        std::optional<TxByte> reply_end;
        while (!queue_.empty() && queue_.front().at <= now && n < burst.size()) {
            burst[n++] = queue_.front().value;
            if (queue_.front().reply_end) {
                reply_end = queue_.front();
            }
            queue_.pop_front();
        }
        const rtu::Instant before = sys::now();
        const auto wrote = sys::posix_call("write", [&] { return ::write(fd_, burst.data(), n); });
        const std::size_t sent = wrote ? static_cast<std::size_t>(*wrote) : 0;
        written_ += sent;
        lost_ += n - sent;
        // The bytes left somewhere between the two readings of the clock.
        last_write_ = {before, sys::now()};
        if (reply_end && on_reply_end_) {
            on_reply_end_(last_write_->second, reply_end->address, reply_end->function);
        }
    }
    timer_.disarm();
}

}  // namespace drivebus::sim
