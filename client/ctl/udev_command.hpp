// SPDX-License-Identifier: Apache-2.0
// drivebusctl udev-rule: reads the devices (through sd-device, or from files of
// `udevadm info --query=property` output) and prints the rules file udev_rule.hpp makes. It
// needs neither drivebusd nor iceoryx.
#pragma once

#include <string>
#include <vector>

#include "udev_rule.hpp"

namespace drivebus::ctl {

struct UdevRuleArgs {
    std::string device;                   // DEVICE: /dev/ttyUSB0, ttyUSB0, /dev/serial/by-id/..., /dev/gpiochip0
    std::vector<std::string> properties;  // --properties FILE: one device each, a tty or a GPIO chip
    std::vector<std::string> gpio_chips;  // --gpio-chip NAME: gpiochipN, /dev/gpiochipN, N or a label
    std::string config;                   // --config FILE: the GPIO chips of its direction = "gpio" buses
    std::string profile_dir;              // --profile-dir DIR: drivebusd reads the config's profiles there
    udev::PortChoice choice;
};

// Prints the rules file on stdout and returns 0, or one line on stderr and 2 (usage), 3 (the
// device cannot be named safely) or 5 (no such device or file).
int run_udev_rule(const UdevRuleArgs& args);

}  // namespace drivebus::ctl
