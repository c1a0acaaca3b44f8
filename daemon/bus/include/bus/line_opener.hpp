// SPDX-License-Identifier: Apache-2.0
// Opens a bus's port and its driver-enable control, and keeps the reopen back-off when that
// fails or the line goes away (100 ms, doubling to 5 s). Runs on the bus thread: it logs
// through the thread's log ring, rate-limited so that a missing adapter is one line a minute.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "config/config.hpp"
#include "log/log.hpp"
#include "serial/direction.hpp"
#include "serial/port.hpp"

namespace drivebus::bus {

// The bus's driver-enable control on the open port `fd`: its direction method, or for
// "kernel" with a kernel_fallback, the fallback when the driver has no RS485 support.
[[nodiscard]] std::expected<std::unique_ptr<serial::Direction>, serial::DirectionError> make_direction(
    const config::BusConfig& bus, int fd, serial::UartControl& uart);

// What can be known of the line before the bus thread starts. When its device is there, the
// port is opened and its direction control made once, then both released. A permanent refusal
// (a driver without RS485 support and no kernel_fallback; a driver that does not keep the RS485
// settings asked, fallback or not; a GPIO chip or line that does not exist) is the
// configuration's: its one line, for drivebusd to exit 78 rather than retry for
// ever. A device that is not there yet (an adapter not plugged in), or busy, is left to the
// bus thread, which waits for it.
[[nodiscard]] std::expected<void, std::string> check_line(const config::BusConfig& bus);

// A direction control's error and, for a permanent refusal of "kernel", what to change.
[[nodiscard]] std::string refusal(const config::BusConfig& bus, const serial::DirectionError& error);

class LineOpener {
public:
    struct Line {
        serial::Port port;
        std::unique_ptr<serial::Direction> direction;
    };

    LineOpener(const config::BusConfig& bus, serial::UartControl& uart) : bus_(bus), uart_(uart) {}

    // Opens the port and its direction control now. On failure the error is logged and the
    // next try scheduled (next_try()).
    [[nodiscard]] std::optional<Line> open(rtu::Instant now);
    // The line that was open failed (or could not be used): try again after the back-off.
    void failed(const std::string& why, bool gone, rtu::Instant now);
    // When to try again, if a try is due.
    [[nodiscard]] std::optional<rtu::Instant> next_try() const noexcept { return reopen_at_; }

private:
    const config::BusConfig& bus_;
    serial::UartControl& uart_;
    rtu::Duration reopen_delay_{};
    std::optional<rtu::Instant> reopen_at_;
    log::RateLimited limiter_{std::chrono::seconds(60)};
};

}  // namespace drivebus::bus
