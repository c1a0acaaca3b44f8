// SPDX-License-Identifier: Apache-2.0
// Built when libgpiod's C++ bindings were not found (Debian: libgpiod-dev).
#include "serial/gpio_line.hpp"

namespace drivebus::serial {

std::expected<std::unique_ptr<OutputLine>, DirectionError> open_gpio_line(const GpioOptions& options) {
    return std::unexpected(DirectionError{describe(options) + ": drivebusd was built without libgpiod", true});
}

}  // namespace drivebus::serial
