// Writes planned bytes to the line at their times: a timerfd wakes the loop shortly before a
// byte is due and the last stretch is busy-waited, so characters leave within microseconds of
// their schedule and never before it.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

#include "bus.hpp"
#include "sys/event_loop.hpp"

namespace drivebus::sim {

class PacedWriter {
public:
    PacedWriter(int fd, rtu::Duration spin);

    [[nodiscard]] int timer_fd() const noexcept { return timer_.fd(); }
    void enqueue(const TxPlan& plan);
    // Writes what is due (busy-waiting for bytes due within the spin window) and re-arms.
    void service();

    [[nodiscard]] std::uint64_t written() const noexcept { return written_; }
    [[nodiscard]] std::uint64_t lost() const noexcept { return lost_; }
    [[nodiscard]] bool idle() const noexcept { return queue_.empty(); }
    // When the last byte was written, if any.
    [[nodiscard]] std::optional<rtu::Instant> last_written() const noexcept { return last_written_; }

private:
    int fd_;
    rtu::Duration spin_;
    sys::Timer timer_;
    std::deque<TxByte> queue_;
    std::uint64_t written_ = 0;
    std::uint64_t lost_ = 0;  // bytes the other end did not take (its buffer was full)
    std::optional<rtu::Instant> last_written_;
};

}  // namespace drivebus::sim
