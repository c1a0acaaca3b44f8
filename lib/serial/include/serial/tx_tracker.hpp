// SPDX-License-Identifier: Apache-2.0
// When the last stop bit of a request has left the UART. The gpio and rts direction methods
// release the driver then, and the master's response timeout starts then: a request of
// 256 bytes is 133 ms on the wire at 19200 bit/s, so timing from write() would eat the
// timeout, and releasing late would collide with a fast slave's reply.
//
// Pure apart from UartControl: time is always an argument.
#pragma once

#include <cstddef>
#include <optional>

#include "rtu/timing.hpp"
#include "serial/port.hpp"

namespace drivebus::serial {

class TransmitTracker {
public:
    // `uart` must outlive the tracker; `fd` is the port's.
    TransmitTracker(rtu::CharacterTiming timing, UartControl& uart, int fd) noexcept;

    // write() of `bytes` returned at `written`. Writes while busy queue behind the earlier ones.
    void started(rtu::Instant written, std::size_t bytes) noexcept;

    // When the loop should look next: first the computed end of the wire time
    // (max(written, previous computed end) + bytes * character time).
    [[nodiscard]] rtu::Instant next_check() const noexcept { return next_check_; }

    // At or after next_check(): the time the transmitter was found (or, when TIOCSERGETLSR is
    // not supported, computed to be) empty; nullopt means not yet, look again at next_check(),
    // which then moves by a quarter character time. Gives up (returns the time) after a cap of
    // 2x the wire time + 20 ms so a stuck UART cannot stall the bus. Before next_check() it
    // answers nullopt without asking the UART. When idle it returns the last result.
    [[nodiscard]] std::optional<rtu::Instant> check(rtu::Instant now);

    [[nodiscard]] bool busy() const noexcept { return busy_; }
    // The computed end of the wire time of everything written so far.
    [[nodiscard]] rtu::Instant computed_end() const noexcept { return computed_end_; }
    // The give-up time of the current transmission.
    [[nodiscard]] rtu::Instant cap() const noexcept { return cap_; }
    // False once the driver answered that it cannot tell (then only the computed time is used).
    [[nodiscard]] bool lsr_supported() const noexcept { return lsr_supported_; }
    // How many transmissions ended at the cap instead of an empty transmitter.
    [[nodiscard]] std::size_t gave_up() const noexcept { return gave_up_; }

    static constexpr rtu::Duration kCapSlack = std::chrono::milliseconds(20);

private:
    rtu::CharacterTiming timing_;
    UartControl* uart_;
    int fd_;
    bool busy_ = false;
    bool lsr_supported_ = true;
    bool polled_ = false;  // TIOCSERGETLSR said "not empty" during this transmission
    rtu::Instant computed_end_{};
    rtu::Instant next_check_{};
    rtu::Instant cap_{};
    rtu::Instant last_done_{};
    std::size_t gave_up_ = 0;
};

}  // namespace drivebus::serial
