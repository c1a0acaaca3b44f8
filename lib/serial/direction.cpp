// SPDX-License-Identifier: Apache-2.0
#include "serial/direction.hpp"

#include <linux/serial.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <optional>

#include "serial/gpio_line.hpp"

namespace drivebus::serial {
namespace {

constexpr int kENOIOCTLCMD = 515;  // Linux's internal "not handled", seen from some drivers

// "/dev/ttyS1" for messages, from the descriptor alone.
std::string device_of(int fd) {
    std::array<char, 256> name{};
    if (::ttyname_r(fd, name.data(), name.size()) == 0) {
        return name.data();
    }
    return "fd " + std::to_string(fd);
}

// The common part of the methods: the driver's state, edges recorded when it changes. A
// repeated before_transmit() (a request written in several pieces) is not a new edge.
class SwitchedDirection : public Direction {
public:
    std::expected<void, DirectionError> before_transmit(rtu::Instant now) final { return change(now, true); }
    std::expected<void, DirectionError> transmit_done(rtu::Instant now) final { return change(now, false); }

protected:
    // Drives the hardware; nothing for the methods where something else switches.
    virtual std::expected<void, DirectionError> drive(bool enable) = 0;
    // Known after a successful drive(); unknown when the first one failed.
    void assume(std::optional<bool> enabled) { enabled_ = enabled; }

private:
    std::expected<void, DirectionError> change(rtu::Instant now, bool enable) {
        if (enabled_ == enable) {
            return {};
        }
        if (auto driven = drive(enable); !driven) {
            enabled_.reset();
            return driven;
        }
        enabled_ = enable;
        record(now, enable);
        return {};
    }

    std::optional<bool> enabled_ = false;
};

class KernelDirection final : public SwitchedDirection {
public:
    [[nodiscard]] std::string_view name() const noexcept override { return "kernel"; }
    [[nodiscard]] bool needs_release() const noexcept override { return false; }

private:
    // The UART driver raises RTS when its transmit queue fills and drops it after the last
    // stop bit (plus delay_rts_after_send); the edges recorded are when we handed it bytes.
    std::expected<void, DirectionError> drive(bool /*enable*/) override { return {}; }
};

class NoDirection final : public SwitchedDirection {
public:
    [[nodiscard]] std::string_view name() const noexcept override { return "none"; }
    [[nodiscard]] bool needs_release() const noexcept override { return false; }

private:
    std::expected<void, DirectionError> drive(bool /*enable*/) override { return {}; }
};

class GpioDirection final : public SwitchedDirection {
public:
    explicit GpioDirection(std::unique_ptr<OutputLine> line) : line_(std::move(line)) {}
    [[nodiscard]] std::string_view name() const noexcept override { return "gpio"; }
    [[nodiscard]] bool needs_release() const noexcept override { return true; }

private:
    std::expected<void, DirectionError> drive(bool enable) override { return line_->set(enable); }
    std::unique_ptr<OutputLine> line_;
};

class RtsDirection final : public SwitchedDirection {
public:
    RtsDirection(int fd, UartControl& uart, RtsOptions options) : fd_(fd), uart_(&uart), options_(options) {
        // Opening the tty raised RTS, which on many boards has the driver enabled already.
        if (!drive(false)) {
            assume(std::nullopt);
        }
    }
    [[nodiscard]] std::string_view name() const noexcept override { return "rts"; }
    [[nodiscard]] bool needs_release() const noexcept override { return true; }

private:
    std::expected<void, DirectionError> drive(bool enable) override {
        const bool rts = enable == options_.rts_on_send;
        if (auto set = uart_->set_rts(fd_, rts); !set) {
            return std::unexpected(DirectionError{device_of(fd_) + ": RTS " + (rts ? "on" : "off") +
                                                  " for the driver " + (enable ? "enable" : "release") + ": " +
                                                  set.error().message()});
        }
        return {};
    }

    int fd_;
    UartControl* uart_;
    RtsOptions options_;
};

// The SER_RS485_* flags we set and compare; the driver may carry others (TERMINATE_BUS...).
constexpr std::uint32_t kOurFlags =
    SER_RS485_ENABLED | SER_RS485_RTS_ON_SEND | SER_RS485_RTS_AFTER_SEND | SER_RS485_RX_DURING_TX;

std::string rs485_differences(const serial_rs485& wanted, const serial_rs485& got) {
    std::string out;
    const auto note = [&](const char* label, std::uint32_t asked, std::uint32_t taken, const char* unit) {
        if (asked != taken) {
            out += (out.empty() ? "" : ", ") + std::string(label) + " " + std::to_string(asked) + " -> " +
                   std::to_string(taken) + unit;
        }
    };
    const auto flag = [&](std::uint32_t bit, const char* label) {
        note(label, (wanted.flags & bit) != 0 ? 1U : 0U, (got.flags & bit) != 0 ? 1U : 0U, "");
    };
    flag(SER_RS485_ENABLED, "enabled");
    flag(SER_RS485_RTS_ON_SEND, "rts_on_send");
    flag(SER_RS485_RTS_AFTER_SEND, "rts_after_send");
    flag(SER_RS485_RX_DURING_TX, "rx_during_tx");
    note("delay_rts_before_send", wanted.delay_rts_before_send, got.delay_rts_before_send, " ms");
    note("delay_rts_after_send", wanted.delay_rts_after_send, got.delay_rts_after_send, " ms");
    return out;
}

}  // namespace

std::expected<std::unique_ptr<Direction>, DirectionError> make_kernel_direction(int fd,
                                                                                const KernelRs485Options& options) {
    const auto failed = [&](const char* call, int error) {
        const std::string why = std::string(call) + ": " + std::strerror(error);
        if (error == ENOTTY || error == EINVAL || error == kENOIOCTLCMD) {
            return std::unexpected(
                DirectionError{.message = device_of(fd) + ": the driver has no RS485 support (" + why + ")",
                               .permanent = true,
                               .no_rs485_support = true});
        }
        return std::unexpected(DirectionError{device_of(fd) + ": kernel RS485 (" + why + ")"});
    };
    // Start from the driver's own settings so that fields we do not manage survive.
    serial_rs485 conf{};
    if (auto got = sys::posix_call("TIOCGRS485", [&] { return ::ioctl(fd, TIOCGRS485, &conf); }); !got) {
        return failed("TIOCGRS485", got.error().error);
    }
    conf.flags &= ~kOurFlags;
    conf.flags |= SER_RS485_ENABLED;
    conf.flags |= options.rts_on_send ? SER_RS485_RTS_ON_SEND : 0U;
    conf.flags |= options.rts_after_send ? SER_RS485_RTS_AFTER_SEND : 0U;
    conf.flags |= options.rx_during_tx ? SER_RS485_RX_DURING_TX : 0U;
    conf.delay_rts_before_send = options.delay_before_send_ms;
    conf.delay_rts_after_send = options.delay_after_send_ms;
    const serial_rs485 wanted = conf;
    if (auto set = sys::posix_call("TIOCSRS485", [&] { return ::ioctl(fd, TIOCSRS485, &conf); }); !set) {
        return failed("TIOCSRS485", set.error().error);
    }
    // Drivers adjust what they cannot do (clamp delays, drop RX_DURING_TX, fix equal RTS
    // levels) without failing: read back and refuse a configuration we did not ask for.
    serial_rs485 got{};
    if (auto read = sys::posix_call("TIOCGRS485", [&] { return ::ioctl(fd, TIOCGRS485, &got); }); !read) {
        return failed("TIOCGRS485", read.error().error);
    }
    if (auto changed = rs485_differences(wanted, got); !changed.empty()) {
        return std::unexpected(
            DirectionError{device_of(fd) + ": the driver changed the RS485 settings: " + changed, true});
    }
    return std::make_unique<KernelDirection>();
}

std::expected<std::unique_ptr<Direction>, DirectionError> make_gpio_direction(const GpioOptions& options) {
    if (gpio_chips().empty()) {
        return std::unexpected(DirectionError{describe(options) + ": " + no_such_chip({}), true});
    }
    auto line = open_gpio_line(options);
    if (!line) {
        return std::unexpected(line.error());
    }
    return make_gpio_direction(std::move(*line));
}

std::unique_ptr<Direction> make_gpio_direction(std::unique_ptr<OutputLine> line) {
    return std::make_unique<GpioDirection>(std::move(line));
}

std::unique_ptr<Direction> make_rts_direction(int fd, UartControl& uart) {
    return make_rts_direction(fd, uart, RtsOptions{});
}

std::unique_ptr<Direction> make_rts_direction(int fd, UartControl& uart, const RtsOptions& options) {
    return std::make_unique<RtsDirection>(fd, uart, options);
}

std::unique_ptr<Direction> make_no_direction() {
    return std::make_unique<NoDirection>();
}

}  // namespace drivebus::serial
