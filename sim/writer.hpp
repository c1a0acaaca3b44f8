// SPDX-License-Identifier: Apache-2.0
// Writes planned bytes to the line at their times: a timerfd wakes the loop shortly before a
// byte is due and the last stretch is busy-waited, so characters leave within microseconds of
// their schedule and never before it.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>

#include "bus.hpp"
#include "sys/event_loop.hpp"

namespace drivebus::sim {

class PacedWriter {
public:
    // `slip`: a byte written later than its time by more than this breaks the pacing (on a
    // real line it would have been a gap inside the frame).
    PacedWriter(int fd, rtu::Duration spin, rtu::Duration slip);

    [[nodiscard]] int timer_fd() const noexcept { return timer_.fd(); }
    void enqueue(const TxPlan& plan);
    // Called after the write() that sent the last byte of a reply, with the clock read then.
    void on_reply_end(std::function<void(rtu::Instant, std::uint8_t address, std::uint8_t function)> callback) {
        on_reply_end_ = std::move(callback);
    }
    // Writes what is due (busy-waiting for bytes due within the spin window) and re-arms.
    void service();

    [[nodiscard]] std::uint64_t written() const noexcept { return written_; }
    [[nodiscard]] std::uint64_t lost() const noexcept { return lost_; }
    [[nodiscard]] bool idle() const noexcept { return queue_.empty(); }
    // Whether a byte went out late by more than the slip since the last clear_slip(); and how
    // many such slips there were in all.
    [[nodiscard]] bool slipped() const noexcept { return slipped_; }
    void clear_slip() noexcept { slipped_ = false; }
    // Whether a queued byte is already later than its time by more than the slip at `now`:
    // the simulator has stalled in the middle of a reply.
    [[nodiscard]] bool stalled(rtu::Instant now) const noexcept {
        return !queue_.empty() && now - queue_.front().at > slip_;
    }
    [[nodiscard]] std::uint64_t slips() const noexcept { return slips_; }
    // When the last write happened, if any: the clock just before and just after write().
    [[nodiscard]] std::optional<std::pair<rtu::Instant, rtu::Instant>> last_write() const noexcept {
        return last_write_;
    }

private:
    int fd_;
    rtu::Duration spin_;
    rtu::Duration slip_;
    bool slipped_ = false;
    std::uint64_t slips_ = 0;
    sys::Timer timer_;
    std::deque<TxByte> queue_;
    std::uint64_t written_ = 0;
    std::uint64_t lost_ = 0;  // bytes the other end did not take (its buffer was full)
    std::optional<std::pair<rtu::Instant, rtu::Instant>> last_write_;
    std::function<void(rtu::Instant, std::uint8_t, std::uint8_t)> on_reply_end_;
};

}  // namespace drivebus::sim
