// SPDX-License-Identifier: Apache-2.0
#include "bus/line_opener.hpp"

#include <algorithm>

#include "serial/termios.hpp"

namespace drivebus::bus {

using namespace std::chrono_literals;

std::optional<LineOpener::Line> LineOpener::open(rtu::Instant now) {
    serial::PortOptions options{bus_.device, bus_.format, bus_.lock_dir};
    auto port = serial::Port::open(options);
    if (!port) {
        failed(port.error().message, port.error().device_gone(), now);
        return std::nullopt;
    }
    auto direction = make_direction(port->fd());
    if (!direction) {
        failed(direction.error().message, false, now);
        return std::nullopt;
    }
    for (const auto& note : port->tuning()) {
        log::info("bus " + bus_.name + ": " + port->device().string() + ": " + note);
    }
    log::notice("bus " + bus_.name + ": " + port->device().string() + " open, " + serial::describe(bus_.format) +
                ", direction " + std::string((*direction)->name()));
    reopen_delay_ = {};
    reopen_at_.reset();
    limiter_.reset("open");
    return Line{std::move(*port), std::move(*direction)};
}

void LineOpener::failed(const std::string& why, bool gone, rtu::Instant now) {
    reopen_delay_ = reopen_delay_.count() == 0 ? rtu::Duration(100ms) : std::min<rtu::Duration>(reopen_delay_ * 2, 5s);
    reopen_at_ = now + reopen_delay_;
    limiter_.write(log::Level::Error, "open",
                   "bus " + bus_.name + ": " + why + (gone ? "; bus down, retrying" : "; retrying"));
}

std::expected<std::unique_ptr<serial::Direction>, serial::DirectionError> LineOpener::make_direction(int fd) {
    switch (bus_.direction) {
    case config::DirectionMode::Kernel: {
        auto kernel = serial::make_kernel_direction(fd, bus_.kernel);
        if (kernel || !bus_.kernel_fallback) {
            return kernel;
        }
        log::warning("bus " + bus_.name + ": " + kernel.error().message + "; falling back to " +
                     std::string(config::to_string(*bus_.kernel_fallback)));
        if (*bus_.kernel_fallback == config::DirectionMode::Rts) {
            return serial::make_rts_direction(fd, uart_);
        }
        return serial::make_no_direction();
    }
    case config::DirectionMode::Gpio: return serial::make_gpio_direction(*bus_.gpio);
    case config::DirectionMode::Rts: return serial::make_rts_direction(fd, uart_);
    case config::DirectionMode::None: return serial::make_no_direction();
    }
    return serial::make_no_direction();
}

}  // namespace drivebus::bus
