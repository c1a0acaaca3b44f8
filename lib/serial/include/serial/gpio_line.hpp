// SPDX-License-Identifier: Apache-2.0
// A GPIO line as the gpio direction method's OutputLine. libgpiod is linked into its own
// small library (drivebus_gpio), so that it is the only code that needs the library; built
// without libgpiod, opening a line fails with a message saying so.
#pragma once

#include <algorithm>
#include <cerrno>
#include <expected>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "serial/direction.hpp"

namespace drivebus::serial {

// "gpio gpiochip0 line 17", the start of every message about the line.
[[nodiscard]] inline std::string describe(const GpioOptions& options) {
    return "gpio " + options.chip + " line " + std::to_string(options.line);
}

// The GPIO character devices present ("gpiochip0", ...), sorted.
[[nodiscard]] inline std::vector<std::string> gpio_chips(const std::filesystem::path& dev = "/dev") {
    std::vector<std::string> chips;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(dev, ec)) {
        auto name = entry.path().filename().string();
        if (name.starts_with("gpiochip")) {
            chips.push_back(std::move(name));
        }
    }
    std::ranges::sort(chips);
    return chips;
}

// "no such GPIO chip (there are gpiochip0, gpiochip1)", or that the machine has none.
[[nodiscard]] inline std::string no_such_chip(const std::vector<std::string>& chips) {
    if (chips.empty()) {
        return "no such GPIO chip (no /dev/gpiochip* on this machine)";
    }
    std::string list;
    for (const auto& name : chips) {
        list += (list.empty() ? "" : ", ") + name;
    }
    return "no such GPIO chip (there are " + list + ")";
}

// Whether opening a chip failed because there is none by that name (ENOENT), or it is not a
// GPIO chip (ENODEV, ENOTTY: /dev/null, a regular file): a configuration error, not a fault.
[[nodiscard]] inline bool is_no_chip(int error) {
    return error == ENOENT || error == ENODEV || error == ENOTTY;
}

// Opens the chip (by name, path, label or number), requests the line as an output of
// consumer "drivebusd", active-low if asked, at its inactive level.
[[nodiscard]] std::expected<std::unique_ptr<OutputLine>, DirectionError> open_gpio_line(const GpioOptions& options);

}  // namespace drivebus::serial
