// SPDX-License-Identifier: Apache-2.0
#include "udev_rule.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "udev_detail.hpp"

namespace drivebus::ctl::udev {
namespace {

using namespace detail;  // NOLINT(google-build-using-namespace): this folder's own helpers

// Checks the values a rule quotes; the first unsafe one is the error (Refused: it comes from
// the device).
std::optional<RuleError> check_values(const Properties& p, std::initializer_list<std::string_view> keys) {
    for (const auto key : keys) {
        if (auto e = check_value(key, property(p, key))) {
            return e;
        }
    }
    return std::nullopt;
}

std::optional<RuleError> check_devpath(const Properties& p, std::string_view what) {
    const auto devpath = property(p, "DEVPATH");
    if (devpath.empty()) {
        return error(RuleErrorKind::Refused,
                     fmt::format("{} has no DEVPATH: a rule could match it only by its kernel name, which "
                                 "drivebusctl does not write (give the output of udevadm info --query=property)",
                                 what));
    }
    if (!devpath.starts_with("/devices/")) {
        return error(RuleErrorKind::Refused,
                     fmt::format("{}: DEVPATH {} is not under /devices/", what, shown(devpath)));
    }
    if (devpath.starts_with("/devices/virtual/")) {
        return error(RuleErrorKind::Refused,
                     fmt::format("{} is a virtual device ({}), not a UART or adapter", what, shown(devpath)));
    }
    return check_values(p, {"DEVPATH"});
}

struct PortRules {
    std::string description;         // for the header: "FTDI FT232R (0403:6001), serial number A10KXYZ1"
    std::vector<std::string> lines;  // comments and rules
};

std::string naming(const std::string& match, const PortChoice& choice) {
    auto line = fmt::format("{}, SYMLINK+=\"drivebus/{}\", GROUP=\"{}\", MODE=\"0660\", TAG+=\"systemd\"", match,
                            choice.name, choice.group);
    if (!choice.start_unit.empty()) {
        line += fmt::format(", ENV{{SYSTEMD_WANTS}}+=\"{}\"", choice.start_unit);
    }
    return line;
}

Result<PortRules> usb_rules(const Properties& p, const PortChoice& choice) {
    const auto vendor = lower(property(p, "ID_VENDOR_ID"));
    const auto model = lower(property(p, "ID_MODEL_ID"));
    if (!hex4(vendor) || !hex4(model)) {
        return std::unexpected(
            error(RuleErrorKind::Refused,
                  fmt::format("ID_VENDOR_ID {} and ID_MODEL_ID {} are not USB IDs (4 hexadecimal digits each)",
                              shown(vendor), shown(model))));
    }
    PortRules out;
    out.description = usb_description(p);
    const auto interface = property(p, "ID_USB_INTERFACE_NUM");
    if (auto e = check_values(p, {"ID_USB_INTERFACE_NUM"})) {
        return std::unexpected(*e);
    }
    auto match = fmt::format(R"(ENV{{ID_VENDOR_ID}}=="{}", ENV{{ID_MODEL_ID}}=="{}")", vendor, model);
    out.lines.emplace_back(
        "# The USB identity (usb_id builtin; 60-serial.rules imports it too, but sorts after this file).");
    out.lines.emplace_back(R"(SUBSYSTEMS=="usb", IMPORT{builtin}="usb_id")");
    if (choice.by_path) {
        const auto path = property(p, "ID_PATH");
        if (path.empty()) {
            return std::unexpected(error(RuleErrorKind::Refused,
                                         fmt::format("{} has no ID_PATH: its USB port is not known", out.description)));
        }
        if (auto e = check_values(p, {"ID_PATH"})) {
            return std::unexpected(*e);
        }
        out.description += fmt::format(", USB port {}", path);
        out.lines.emplace_back(R"(IMPORT{builtin}="path_id")");
        out.lines.emplace_back(
            "# By the USB port it is plugged into (ID_PATH, as in /dev/serial/by-path/), as asked with --by-path:");
        out.lines.emplace_back(
            "# another adapter of this model in this port gets the name, and this one moved to another port (or");
        out.lines.emplace_back("# behind another hub) loses it.");
        match += fmt::format(R"(, ENV{{ID_PATH}}=="{}")", path);
    } else {
        const auto serial = property(p, "ID_SERIAL_SHORT");
        if (serial.empty()) {
            return std::unexpected(error(
                RuleErrorKind::Refused,
                fmt::format("{} has no serial number (no ID_SERIAL_SHORT): it can be named only by the USB port it "
                            "is plugged into; run again with --by-path for that",
                            out.description)));
        }
        if (auto e = check_values(p, {"ID_SERIAL_SHORT"})) {
            return std::unexpected(*e);
        }
        if (generic_serial(serial)) {
            return std::unexpected(error(
                RuleErrorKind::Refused,
                fmt::format("{} reports the serial number {}, which many adapters of its kind share: run again with "
                            "--by-path to name it by its USB port instead",
                            out.description, shown(serial))));
        }
        out.description += fmt::format(", serial number {}", serial);
        match += fmt::format(R"(, ENV{{ID_SERIAL_SHORT}}=="{}")", serial);
    }
    if (!interface.empty()) {
        out.description += fmt::format(", USB interface {}", interface);
        // The port of a chip with several (FT2232, FT4232, CP2105): they share one serial number.
        match += fmt::format(R"(, ENV{{ID_USB_INTERFACE_NUM}}=="{}")", interface);
    }
    out.lines.push_back(naming(match, choice));
    if (is_ftdi(p)) {
        out.lines.emplace_back(
            "# FTDI: a 1 ms latency timer on this adapter (the default 16 ms holds received bytes back and spoils");
        out.lines.emplace_back(
            "# the inter-character timing drivebusd measures). The attribute is the usb-serial port's, the tty's "
            "parent.");
        out.lines.push_back(match + R"(, TEST=="device/latency_timer", ATTR{device/latency_timer}="1")");
    }
    return out;
}

Result<PortRules> board_rules(const Properties& p, const PortChoice& choice) {
    const auto devpath = std::string(property(p, "DEVPATH"));
    const auto name = basename(property(p, "DEVNAME"));
    const auto driver = property(p, "DRIVER");
    PortRules out;
    out.description = fmt::format("the UART {}at {}", name.empty() ? "" : std::string(name) + " ", devpath);
    out.lines.emplace_back(fmt::format(
        "# A UART of the board{}{}, by its device path (DEVPATH), not by its kernel name.",
        name.empty() ? "" : " (" + std::string(name) + ")", driver.empty() ? "" : fmt::format(", driver {}", driver)));
    out.lines.emplace_back(
        "# Make sure it is not the serial console (console= on the kernel command line) nor wired to Bluetooth.");
    const auto match = fmt::format(R"(DEVPATH=="{}")", devpath);
    out.lines.push_back(naming(match, choice));
    if (is_8250(p)) {
        out.lines.emplace_back(
            "# 8250/16550: interrupt on the first received byte instead of a FIFO threshold (drivebusd asks for it");
        out.lines.emplace_back("# too but, unprivileged, cannot write the root-owned attribute).");
        out.lines.push_back(match + R"(, TEST=="rx_trig_bytes", ATTR{rx_trig_bytes}="1")");
    }
    return out;
}

Result<PortRules> port_rules(const Properties& p, const PortChoice& choice) {
    const auto subsystem = property(p, "SUBSYSTEM");
    const auto what = property(p, "DEVNAME").empty() ? std::string("the device") : std::string(property(p, "DEVNAME"));
    if (subsystem != "tty") {
        return std::unexpected(
            error(RuleErrorKind::Refused, fmt::format("{} is not a serial port (SUBSYSTEM={})", what,
                                                      subsystem.empty() ? std::string("none") : shown(subsystem))));
    }
    // Every value that reaches the file, comments included: a newline would start a rule.
    if (auto e = check_values(p, {"DEVNAME", "ID_USB_DRIVER", "DRIVER"})) {
        return std::unexpected(*e);
    }
    if (auto e = check_devpath(p, what)) {
        return std::unexpected(*e);
    }
    const bool usb = property(p, "ID_BUS") == "usb" || !property(p, "ID_VENDOR_ID").empty();
    if (usb) {
        return usb_rules(p, choice);
    }
    if (property(p, "DEVPATH").find("/usb") != std::string_view::npos) {
        return std::unexpected(
            error(RuleErrorKind::Refused,
                  fmt::format("{} is on USB but has no USB identity (ID_VENDOR_ID, ID_MODEL_ID): udev's usb_id has "
                              "not run on it",
                              what)));
    }
    return board_rules(p, choice);
}

Result<std::vector<std::string>> chip_rules(const GpioChip& chip) {
    const auto& p = chip.properties;
    const auto devname = property(p, "DEVNAME");
    const auto what = devname.empty() ? std::string("the GPIO chip") : std::string(devname);
    if (property(p, "SUBSYSTEM") != "gpio" || !basename(devname).starts_with("gpiochip")) {
        return std::unexpected(
            error(RuleErrorKind::Refused, fmt::format("{} is not a GPIO chip (SUBSYSTEM={}, DEVNAME={})", what,
                                                      shown(property(p, "SUBSYSTEM")), shown(devname))));
    }
    if (auto e = check_values(p, {"DEVNAME"})) {
        return std::unexpected(*e);
    }
    if (auto e = check_devpath(p, what)) {
        return std::unexpected(*e);
    }
    if (auto e = check_value("the chip's label", chip.label)) {
        return std::unexpected(*e);
    }
    std::vector<std::string> lines;
    lines.push_back(fmt::format("# GPIO chip {}{}, by its device path (DEVPATH).", basename(devname),
                                chip.label.empty() ? "" : fmt::format(" (label {})", chip.label)));
    std::string used;
    for (const auto& use : chip.uses) {
        used += fmt::format("{}bus '{}' drives its transceiver's enable on line {}", used.empty() ? "" : "; ", use.bus,
                            use.line);
    }
    if (!used.empty()) {
        lines.push_back("# " + used + ".");
    }
    for (const auto& use : chip.uses) {
        if (auto e = check_value("the bus name", use.bus)) {
            return std::unexpected(*e);
        }
    }
    std::string requested = "only the lines above";
    if (chip.uses.empty()) {
        requested = "only the gpio_line of its configuration";
    } else if (chip.uses.size() == 1) {
        requested = fmt::format("only line {}", chip.uses.front().line);
    }
    lines.push_back(
        fmt::format("# Group {}: only drivebusd is in it. drivebusd requests {};", kDaemonGroup, requested));
    lines.emplace_back("# the kernel gives access to a whole chip, not to single lines, so the group could request");
    lines.emplace_back("# any line of it.");
    lines.push_back(fmt::format(R"(SUBSYSTEM=="gpio", DEVPATH=="{}", GROUP="{}", MODE="0660")", property(p, "DEVPATH"),
                                kDaemonGroup));
    return lines;
}

}  // namespace

Result<std::string> rules_file(const std::optional<Properties>& port, const PortChoice& choice,
                               const std::vector<GpioChip>& chips) {
    if (auto e = check_choice(choice)) {
        return std::unexpected(*e);
    }
    if (!port && chips.empty()) {
        return std::unexpected(error(RuleErrorKind::Usage, "no device to write a rule for"));
    }
    // One rule per chip, whatever number of buses use it.
    std::vector<GpioChip> merged;
    for (const auto& chip : chips) {
        const auto devpath = property(chip.properties, "DEVPATH");
        auto same = std::ranges::find_if(merged, [&](const GpioChip& m) {
            return !devpath.empty() && property(m.properties, "DEVPATH") == devpath;
        });
        if (same == merged.end()) {
            merged.push_back(chip);
        } else {
            same->uses.insert(same->uses.end(), chip.uses.begin(), chip.uses.end());
            if (same->label.empty()) {
                same->label = chip.label;
            }
        }
    }
    std::vector<std::string> gpio_lines;
    for (const auto& chip : merged) {
        auto lines = chip_rules(chip);
        if (!lines) {
            return std::unexpected(lines.error());
        }
        gpio_lines.insert(gpio_lines.end(), lines->begin(), lines->end());
    }
    std::optional<PortRules> port_part;
    if (port) {
        auto rules = port_rules(*port, choice);
        if (!rules) {
            return std::unexpected(rules.error());
        }
        port_part = std::move(*rules);
    }

    const auto path = install_path(port ? std::optional<PortChoice>(choice) : std::nullopt);
    const auto label = label_of(port ? choice.name : std::string("gpio"));
    std::string out;
    const auto add = [&out](std::string_view line) {
        out += line;
        out += '\n';
    };
    add(fmt::format("# {}", path));
    if (port_part) {
        add(fmt::format("# Made by drivebusctl udev-rule: /dev/drivebus/{}, group {}, for", choice.name, choice.group));
        add(fmt::format("# {}.", port_part->description));
    } else {
        add("# Made by drivebusctl udev-rule: the GPIO chips of drivebusd's driver-enable lines.");
    }
    add("#");
    add(fmt::format("# Save it as {} (the groups of drivebus.conf must exist", path));
    add("# first: udev ignores GROUP= with an unknown group), then load it:");
    add("#   sudo udevadm control --reload");
    add(fmt::format("#   sudo udevadm trigger --action=change{}{}", port_part ? " --subsystem-match=tty" : "",
                    merged.empty() ? "" : " --subsystem-match=gpio"));
    if (port_part && port) {
        const auto devname = property(*port, "DEVNAME");
        add(fmt::format(
            "# Check: ls -l /dev/drivebus/; udevadm test $(udevadm info -q path -n {}) 2>&1 | grep drivebus",
            devname.empty() ? std::string_view("DEVICE") : devname));
        add(fmt::format("# drivebusd.toml: device = \"/dev/drivebus/{}\".", choice.name));
        if (choice.start_unit.empty()) {
            add(fmt::format("# TAG+=\"systemd\" makes the unit {}; to have drivebusd wait for the",
                            device_unit(choice.name)));
            add("# adapter, `sudo systemctl edit drivebusd` and add under [Unit]:");
            add(fmt::format("#   Wants={}", device_unit(choice.name)));
            add(fmt::format("#   After={}", device_unit(choice.name)));
        } else {
            add(fmt::format("# The adapter appearing starts {} (ENV{{SYSTEMD_WANTS}}, asked with --start),",
                            choice.start_unit));
            add("# enabled or not.");
        }
    } else {
        add("# Check: ls -l /dev/gpiochip*");
    }
    add("");
    add(fmt::format("ACTION==\"remove\", GOTO=\"{}\"", label));
    if (!gpio_lines.empty()) {
        add("");
        for (const auto& line : gpio_lines) {
            add(line);
        }
    }
    if (port_part) {
        add("");
        add(fmt::format("SUBSYSTEM!=\"tty\", GOTO=\"{}\"", label));
        for (const auto& line : port_part->lines) {
            add(line);
        }
    }
    add("");
    add(fmt::format("LABEL=\"{}\"", label));
    return out;
}

}  // namespace drivebus::ctl::udev
