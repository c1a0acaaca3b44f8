// SPDX-License-Identifier: Apache-2.0
// drivebusctl udev-rule, the pure part: from a device's udev properties (what
// `udevadm info --query=property` prints) and the administrator's choices to the text of a
// rules file that names that one adapter, or a typed refusal. Nothing here reads sysfs or
// udev; tests/ctl/udev_rule_test.cpp covers it, and udev_device.cpp feeds it from sd-device.
//
// What a generated rule never does: match a device by its kernel name (ttyUSB0, ttyAMA0,
// gpiochip0) or by a pattern that could catch another adapter, start a unit unless asked to,
// or give a GPIO chip to anyone but the daemon's own group.
#pragma once

#include <expected>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus::ctl::udev {

// KEY -> VALUE, as udevadm prints them.
using Properties = std::map<std::string, std::string, std::less<>>;

enum class RuleErrorKind {
    Usage,     // a bad choice on the command line (name, group, unit): exit 2
    Refused,   // the device cannot be named safely, or a value from it is unsafe: exit 3
    NotFound,  // no such device or file, or it cannot be read: exit 5
};

struct RuleError {
    RuleErrorKind kind = RuleErrorKind::Usage;
    std::string message;  // one line
};

template <typename T>
using Result = std::expected<T, RuleError>;

// The groups of systemd/drivebus.conf: drivebusd is the daemon's own (SupplementaryGroups= of
// the units; no client is in it).
inline constexpr std::string_view kDaemonGroup = "drivebusd";
inline constexpr std::string_view kDefaultName = "rs485-0";

// The administrator's choices for a serial port.
struct PortChoice {
    std::string name{kDefaultName};   // /dev/drivebus/<name>
    std::string group{kDaemonGroup};  // GROUP= of the port
    bool by_path = false;             // USB: match the USB port (ID_PATH) instead of the serial number
    std::string start_unit;           // ENV{SYSTEMD_WANTS}; empty: none
};

// What a configuration asks of a GPIO chip: bus `bus` drives line `line` of chip `chip`.
struct GpioUse {
    std::string bus;
    std::string chip;  // as written: "gpiochip0", "/dev/gpiochip0", "0" or a label
    long long line = 0;
};

// A GPIO chip to give to the daemon: its properties (SUBSYSTEM=gpio, DEVNAME, DEVPATH), its
// label when known, and the lines drivebusd uses on it (empty: none known).
struct GpioChip {
    Properties properties;
    std::string label;
    std::vector<GpioUse> uses;
};

// `udevadm info --query=property` output (KEY=VALUE lines), or plain `udevadm info` output (its
// "E: KEY=VALUE" lines; the others are skipped).
[[nodiscard]] Result<Properties> parse_properties(std::string_view text);

// A value from outside (a serial number, a device path) that a rule may quote: printable ASCII
// without '"', '\\', the glob characters '*', '?', '[' and udev's alternative '|'. `what` names
// it in the error.
[[nodiscard]] std::optional<RuleError> check_value(std::string_view what, std::string_view value);
// The choices: name [a-z0-9._-] starting with a letter or digit, a group name, a unit name.
[[nodiscard]] std::optional<RuleError> check_choice(const PortChoice& choice);

// A known placeholder serial number that many chips of a kind share ("0001" on CP210x clones,
// "A50285BI" on FT232R clones, all zeros): no better than none.
[[nodiscard]] bool generic_serial(std::string_view serial);

// "gpiochip3" for "gpiochip3", "/dev/gpiochip3" or "3"; nullopt for anything else (a label).
[[nodiscard]] std::optional<std::string> gpio_chip_devname(std::string_view chip);

// The buses with direction = "gpio" of a configuration, from what `drivebusd --config FILE
// --gpio-lines` printed of it (a line "BUS<tab>CHIP<tab>LINE" each: drivebusd reads the file, its
// fragments and the profiles); `source` names the file in errors. None is an error.
[[nodiscard]] Result<std::vector<GpioUse>> gpio_uses(std::string_view lines, std::string_view source);

// systemd's name for the device unit of /dev/drivebus/<name>: dev-drivebus-rs485\x2d0.device.
[[nodiscard]] std::string device_unit(std::string_view name);

// Where the file goes: /etc/udev/rules.d/60-drivebus-<name>.rules (60-drivebus-gpio.rules
// without a port).
[[nodiscard]] std::string install_path(const std::optional<PortChoice>& port);

// The whole rules file: a header (what it names, where to install it, how to load and check
// it), the GPIO rules, then the port's rules. port may be absent (GPIO only); chips may be
// empty. At least one of them must be given.
[[nodiscard]] Result<std::string> rules_file(const std::optional<Properties>& port, const PortChoice& choice,
                                             const std::vector<GpioChip>& chips);

}  // namespace drivebus::ctl::udev
