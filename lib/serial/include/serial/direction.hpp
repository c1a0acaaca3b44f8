// SPDX-License-Identifier: Apache-2.0
// RS485 driver-enable (direction) control. One small class per method:
//   kernel: the UART driver switches RTS itself (TIOCSRS485), configured and read back;
//   gpio:   a GPIO line through libgpiod, asserted before the first character and released
//           as soon as the transmitter is empty;
//   rts:    the RTS modem line, driven the same way by hand;
//   none:   an adapter with automatic direction control.
//
// The bus loop calls before_transmit() just before write(), and transmit_done() once it knows
// the transmitter is empty (TIOCSERGETLSR, or the computed wire time from the write when the
// driver cannot tell). Every edge is recorded with its time.
#pragma once

#include <cstdint>
#include <expected>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rtu/timing.hpp"
#include "serial/options.hpp"
#include "serial/port.hpp"

namespace drivebus::serial {

struct DirectionEdge {
    rtu::Instant at{};
    bool enabled = false;  // driver enabled (transmitting) after this edge
};

struct DirectionError {
    std::string message;  // one line: "gpio /dev/gpiochip0 line 17: No such file or directory"
    // Whether trying again can help: not for a driver without RS485 support, a GPIO chip or line
    // that does not exist, or a build without libgpiod (the configuration asks for what this
    // machine has not); yes for a line in use or an I/O error.
    bool permanent = false;
    // The driver has no RS485 support at all (TIOCSRS485: ENOTTY, EINVAL, ENOIOCTLCMD): the one
    // case a configured kernel_fallback is for. A driver that changed the settings has support
    // and refused what was asked, which no fallback should hide.
    bool no_rs485_support = false;
};

class Direction {
public:
    virtual ~Direction() = default;
    [[nodiscard]] virtual std::string_view name() const noexcept = 0;
    // Just before write(): enable the driver.
    virtual std::expected<void, DirectionError> before_transmit(rtu::Instant now) = 0;
    // The transmitter is empty: release the driver.
    virtual std::expected<void, DirectionError> transmit_done(rtu::Instant now) = 0;
    // Whether the loop must find out when the transmitter is empty to call transmit_done()
    // promptly (gpio, rts); the kernel and automatic adapters switch by themselves.
    [[nodiscard]] virtual bool needs_release() const noexcept = 0;
    [[nodiscard]] const std::vector<DirectionEdge>& edges() const noexcept { return edges_; }
    void clear_edges() noexcept { edges_.clear(); }

protected:
    void record(rtu::Instant at, bool enabled) { edges_.push_back({at, enabled}); }

private:
    std::vector<DirectionEdge> edges_;
};

// The one operation the gpio method needs from a GPIO line, so that tests can record it.
// `active` is the logical level: true enables the driver (active_low is the line's business).
class OutputLine {
public:
    virtual ~OutputLine() = default;
    virtual std::expected<void, DirectionError> set(bool active) = 0;
};

struct RtsOptions {
    // RTS asserted (TIOCMBIS) while sending, as SER_RS485_RTS_ON_SEND; false for boards
    // that enable the driver with RTS deasserted.
    bool rts_on_send = true;
};

// Configures TIOCSRS485 on `fd` and reads it back (TIOCGRS485). Fails with a clear message
// when the driver has no RS485 support (ENOTTY, EINVAL: no_rs485_support, where the caller
// applies the configured fallback) or did not keep the settings asked (permanent too).
[[nodiscard]] std::expected<std::unique_ptr<Direction>, DirectionError> make_kernel_direction(
    int fd, const KernelRs485Options& options);
// Requests the line through libgpiod as an output of consumer "drivebusd", inactive.
[[nodiscard]] std::expected<std::unique_ptr<Direction>, DirectionError> make_gpio_direction(const GpioOptions& options);
// The same over any OutputLine (tests).
[[nodiscard]] std::unique_ptr<Direction> make_gpio_direction(std::unique_ptr<OutputLine> line);
// `uart` must outlive the Direction. The driver is released (RTS to its receive level) here,
// since opening a tty raises RTS; an error doing so shows again at the first before_transmit().
[[nodiscard]] std::unique_ptr<Direction> make_rts_direction(int fd, UartControl& uart);
[[nodiscard]] std::unique_ptr<Direction> make_rts_direction(int fd, UartControl& uart, const RtsOptions& options);
[[nodiscard]] std::unique_ptr<Direction> make_no_direction();

}  // namespace drivebus::serial
