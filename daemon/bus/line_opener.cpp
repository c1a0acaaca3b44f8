// SPDX-License-Identifier: Apache-2.0
#include "bus/line_opener.hpp"

#include <algorithm>
#include <filesystem>

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
    auto direction = make_direction(bus_, port->fd(), uart_);
    if (!direction) {
        failed(direction.error().message, false, now);
        return std::nullopt;
    }
    for (const auto& note : port->tuning()) {
        log::info("bus " + bus_.name + ": " + port->device().string() + ": " + note, {.bus = bus_.name});
    }
    log::notice("bus " + bus_.name + ": " + port->device().string() + " open, " + serial::describe(bus_.format) +
                    ", direction " + std::string((*direction)->name()),
                {.bus = bus_.name});
    reopen_delay_ = {};
    reopen_at_.reset();
    limiter_.reset("open");
    return Line{std::move(*port), std::move(*direction)};
}

void LineOpener::failed(const std::string& why, bool gone, rtu::Instant now) {
    reopen_delay_ = reopen_delay_.count() == 0 ? rtu::Duration(100ms) : std::min<rtu::Duration>(reopen_delay_ * 2, 5s);
    reopen_at_ = now + reopen_delay_;
    limiter_.write(log::Level::Error, "open",
                   "bus " + bus_.name + ": " + why + (gone ? "; bus down, retrying" : "; retrying"),
                   {.bus = bus_.name});
}

std::expected<std::unique_ptr<serial::Direction>, serial::DirectionError> make_direction(const config::BusConfig& bus,
                                                                                         int fd,
                                                                                         serial::UartControl& uart) {
    switch (bus.direction) {
    case config::DirectionMode::Kernel: {
        auto kernel = serial::make_kernel_direction(fd, bus.kernel);
        if (kernel || !bus.kernel_fallback || !kernel.error().no_rs485_support) {
            return kernel;  // a driver that changed what was asked is refused, fallback or not
        }
        log::warning("bus " + bus.name + ": " + kernel.error().message + "; falling back to " +
                         std::string(config::to_string(*bus.kernel_fallback)),
                     {.bus = bus.name});
        if (*bus.kernel_fallback == config::DirectionMode::Rts) {
            return serial::make_rts_direction(fd, uart);
        }
        return serial::make_no_direction();
    }
    case config::DirectionMode::Gpio: return serial::make_gpio_direction(*bus.gpio);
    case config::DirectionMode::Rts: return serial::make_rts_direction(fd, uart);
    case config::DirectionMode::None: return serial::make_no_direction();
    }
    return serial::make_no_direction();
}

std::expected<void, std::string> check_line(const config::BusConfig& bus) {
    std::error_code ec;
    if (!std::filesystem::exists(bus.device, ec)) {
        return {};
    }
    auto port = serial::Port::open({bus.device, bus.format, bus.lock_dir});
    if (!port) {
        return {};  // busy, or gone again: the bus thread retries
    }
    const auto uart = serial::kernel_uart_control();
    const bool kernel = bus.direction == config::DirectionMode::Kernel;
    // The kernel method alone, so that a fallback the bus thread takes is not logged twice.
    auto direction =
        kernel ? serial::make_kernel_direction(port->fd(), bus.kernel) : make_direction(bus, port->fd(), *uart);
    if (direction || !direction.error().permanent) {
        return {};
    }
    const auto& error = direction.error();
    if (kernel && error.no_rs485_support && bus.kernel_fallback) {
        return {};  // the bus thread falls back, as configured
    }
    return std::unexpected("bus " + bus.name + ": " + refusal(bus, error));
}

std::string refusal(const config::BusConfig& bus, const serial::DirectionError& error) {
    if (bus.direction != config::DirectionMode::Kernel || !error.permanent) {
        return error.message;
    }
    return error.message + (error.no_rs485_support
                                ? "; set kernel_fallback = \"rts\" or \"none\", or another direction"
                                : "; ask for what the driver keeps (rts_on_send, rts_after_send, rx_during_tx, "
                                  "delay_before_send_ms, delay_after_send_ms), or another direction");
}

}  // namespace drivebus::bus
