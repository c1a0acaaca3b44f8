// SPDX-License-Identifier: Apache-2.0
// Raw termios for a Modbus RTU line: the configured format, no processing of any kind, and
// optionally INPCK|PARMRK so that characters received with parity or framing errors reach the
// framer marked (see rtu/parmrk.hpp).
#pragma once

#include <expected>
#include <optional>
#include <string>

#include "rtu/timing.hpp"
#include "sys/posix.hpp"

namespace drivebus::serial {

enum class ErrorMarking : std::uint8_t { Off, Parmrk };

// Sets `fd` to raw mode in `format`. Fails for a baud rate termios has no constant for.
[[nodiscard]] std::expected<void, sys::SysError> configure_line(int fd, const rtu::LineFormat& format,
                                                                ErrorMarking marking);

// Whether termios has a constant for `baud` (B9600, B19200, ...).
[[nodiscard]] bool standard_baud(std::uint32_t baud) noexcept;

// "19200 8E1"
[[nodiscard]] std::string describe(const rtu::LineFormat& format);

}  // namespace drivebus::serial
