// SPDX-License-Identifier: Apache-2.0
#include "udev_rule.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>

namespace drivebus::ctl::udev {
namespace {

RuleError error(RuleErrorKind kind, std::string message) {
    return RuleError{kind, std::move(message)};
}

// A value as the error shows it: quoted, with control and non-ASCII bytes as \xNN.
std::string shown(std::string_view value) {
    std::string out = "\"";
    for (const char c : value) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte < 0x20 || byte >= 0x7f) {
            out += fmt::format("\\x{:02x}", byte);
        } else if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else {
            out += c;
        }
    }
    return out + "\"";
}

std::string_view property(const Properties& p, std::string_view key) {
    const auto it = p.find(key);
    return it == p.end() ? std::string_view{} : std::string_view(it->second);
}

std::string_view basename(std::string_view path) {
    const auto slash = path.rfind('/');
    return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

bool all_of(std::string_view s, auto predicate) {
    return !s.empty() && std::ranges::all_of(s, predicate);
}

bool lower_alnum(char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
}

bool hex4(std::string_view s) {
    return s.size() == 4 && std::ranges::all_of(s, [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
}

std::string lower(std::string_view s) {
    std::string out(s);
    std::ranges::transform(out, out.begin(), [](char c) { return static_cast<char>(std::tolower(c)); });
    return out;
}

// The chips whose name the comment can give; the rules work from the driver and the IDs.
struct KnownChip {
    std::string_view vendor;
    std::string_view model;
    std::string_view name;
};
constexpr std::array<KnownChip, 11> kKnownChips = {{
    {"0403", "6001", "FTDI FT232R"},
    {"0403", "6014", "FTDI FT232H"},
    {"0403", "6015", "FTDI FT-X"},
    {"0403", "6010", "FTDI FT2232"},
    {"0403", "6011", "FTDI FT4232"},
    {"10c4", "ea60", "Silicon Labs CP210x"},
    {"10c4", "ea70", "Silicon Labs CP2105"},
    {"10c4", "ea71", "Silicon Labs CP2108"},
    {"1a86", "7523", "WCH CH340"},
    {"1a86", "5523", "WCH CH341"},
    {"067b", "2303", "Prolific PL2303"},
}};

struct KnownDriver {
    std::string_view driver;
    std::string_view name;
};
constexpr std::array<KnownDriver, 5> kKnownDrivers = {{
    {"ftdi_sio", "FTDI adapter"},
    {"cp210x", "Silicon Labs CP210x adapter"},
    {"ch341", "WCH CH34x adapter"},
    {"pl2303", "Prolific PL2303 adapter"},
    {"cdc_acm", "CDC-ACM device"},
}};

// The driver of the USB serial port: ID_USB_DRIVER (usb_id), else DRIVER (the nearest parent's,
// filled in by drivebusctl when it reads the device itself).
std::string_view usb_driver(const Properties& p) {
    const auto id = property(p, "ID_USB_DRIVER");
    return id.empty() ? property(p, "DRIVER") : id;
}

std::string usb_description(const Properties& p) {
    const auto vendor = lower(property(p, "ID_VENDOR_ID"));
    const auto model = lower(property(p, "ID_MODEL_ID"));
    for (const auto& chip : kKnownChips) {
        if (chip.vendor == vendor && chip.model == model) {
            return fmt::format("{} ({}:{})", chip.name, vendor, model);
        }
    }
    const auto driver = usb_driver(p);
    for (const auto& known : kKnownDrivers) {
        if (known.driver == driver) {
            return fmt::format("{} ({}:{})", known.name, vendor, model);
        }
    }
    return driver.empty() ? fmt::format("USB serial adapter ({}:{})", vendor, model)
                          : fmt::format("USB serial adapter ({}:{}, driver {})", vendor, model, driver);
}

bool is_ftdi(const Properties& p) {
    const auto driver = usb_driver(p);
    return driver == "ftdi_sio" || (driver.empty() && lower(property(p, "ID_VENDOR_ID")) == "0403");
}

// An 8250/16550 port: the 8250 core names its ports ttyS<N>; drivebusctl adds the parent's
// driver (serial8250, dw-apb-uart, of_serial, 8250_*) when it reads the device itself.
bool is_8250(const Properties& p) {
    const auto name = basename(property(p, "DEVNAME"));
    if (name.size() > 4 && name.starts_with("ttyS") &&
        std::ranges::all_of(name.substr(4), [](char c) { return c >= '0' && c <= '9'; })) {
        return true;
    }
    const auto driver = property(p, "DRIVER");
    return driver.find("8250") != std::string_view::npos || driver == "dw-apb-uart" || driver == "of_serial";
}

std::string label_of(std::string_view name) {
    std::string out = "drivebus_";
    for (const char c : name) {
        out += lower_alnum(c) ? c : '_';
    }
    return out + "_end";
}

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

Result<Properties> parse_properties(std::string_view text) {
    Properties out;
    std::size_t number = 0;
    while (!text.empty()) {
        const auto end = text.find('\n');
        auto line = text.substr(0, end);
        text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
        ++number;
        if (!line.empty() && line.back() == '\r') {
            line.remove_suffix(1);
        }
        if (line.empty()) {
            continue;
        }
        if (line.size() >= 2 && line[1] == ':') {  // plain `udevadm info`: "E: KEY=VALUE", "P: /devices/..."
            if (line[0] != 'E') {
                continue;
            }
            line.remove_prefix(line.size() > 2 && line[2] == ' ' ? 3 : 2);
        }
        const auto equals = line.find('=');
        const auto key = line.substr(0, std::min(equals, line.size()));
        const bool key_ok =
            all_of(key, [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.'; });
        if (equals == std::string_view::npos || !key_ok) {
            return std::unexpected(
                error(RuleErrorKind::Usage,
                      fmt::format("line {}: {} is not KEY=VALUE (udevadm info --query=property prints that)", number,
                                  shown(line.substr(0, 60)))));
        }
        out[std::string(key)] = std::string(line.substr(equals + 1));
    }
    if (out.empty()) {
        return std::unexpected(
            error(RuleErrorKind::Usage, "no properties (udevadm info --query=property prints them)"));
    }
    return out;
}

std::optional<RuleError> check_value(std::string_view what, std::string_view value) {
    for (const char c : value) {
        const auto byte = static_cast<unsigned char>(c);
        std::string bad;
        if (byte < 0x20 || byte == 0x7f) {
            bad = fmt::format("a control character (\\x{:02x})", byte);
        } else if (byte > 0x7f) {
            bad = "a byte outside printable ASCII";
        } else if (c == '"' || c == '\\') {
            bad = fmt::format("'{}', which would end or escape the rule's quoted value", c);
        } else if (c == '*' || c == '?' || c == '[') {
            bad = fmt::format("'{}', a glob character, which would let the rule match other devices", c);
        } else if (c == '|') {
            bad = "'|', which udev reads as an alternative, so the rule would match other devices";
        }
        if (!bad.empty()) {
            return error(RuleErrorKind::Refused,
                         fmt::format("{} {} contains {}: no rule written", what, shown(value), bad));
        }
    }
    return std::nullopt;
}

std::optional<RuleError> check_choice(const PortChoice& choice) {
    const auto& name = choice.name;
    if (name.empty() || name.size() > 64 || !lower_alnum(name.front()) ||
        !std::ranges::all_of(name, [](char c) { return lower_alnum(c) || c == '.' || c == '_' || c == '-'; })) {
        return error(RuleErrorKind::Usage,
                     fmt::format("--name {}: a name is 1 to 64 of a-z 0-9 . _ - and starts with a letter or digit",
                                 shown(name)));
    }
    const auto& group = choice.group;
    if (group.empty() || group.size() > 32 ||
        (std::islower(static_cast<unsigned char>(group.front())) == 0 && group.front() != '_') ||
        !std::ranges::all_of(group, [](char c) { return lower_alnum(c) || c == '_' || c == '-'; })) {
        return error(RuleErrorKind::Usage,
                     fmt::format("--group {}: a group name is 1 to 32 of a-z 0-9 _ - and starts with a letter or '_'",
                                 shown(group)));
    }
    const auto& unit = choice.start_unit;
    if (!unit.empty()) {
        const bool chars_ok = std::ranges::all_of(unit, [](char c) {
            return std::isalnum(static_cast<unsigned char>(c)) || c == ':' || c == '_' || c == '.' || c == '@' ||
                   c == '-';
        });
        const bool suffix_ok = unit.ends_with(".service") || unit.ends_with(".target");
        if (!chars_ok || !suffix_ok || unit.size() > 255 || unit.starts_with(".") || unit.starts_with("-") ||
            unit.find("@.") != std::string::npos) {
            return error(RuleErrorKind::Usage,
                         fmt::format("--start {}: not a unit name like drivebusd.service or drivebusd@line1.service",
                                     shown(unit)));
        }
    }
    return std::nullopt;
}

bool generic_serial(std::string_view serial) {
    static constexpr std::array<std::string_view, 5> kPlaceholders = {
        "0001",              // CP210x clones, and chips left unprogrammed
        "a50285bi",          // FT232R clones
        "0123456789abcdef",  // CP210x and CH9102 sample serial numbers
        "00000000001a",      // STM32 USB CDC examples
        "123456789",
    };
    if (std::ranges::find(kPlaceholders, lower(serial)) != kPlaceholders.end()) {
        return true;
    }
    // "0000", "FFFFFFFF": one character repeated.
    return std::ranges::all_of(serial, [&](char c) { return c == serial.front(); });
}

std::optional<std::string> gpio_chip_devname(std::string_view chip) {
    if (chip.starts_with("/dev/")) {
        chip.remove_prefix(5);
    }
    if (chip.starts_with("gpiochip")) {
        chip.remove_prefix(8);
    }
    if (chip.empty() || chip.size() > 6 || !std::ranges::all_of(chip, [](char c) { return c >= '0' && c <= '9'; })) {
        return std::nullopt;
    }
    return "gpiochip" + std::string(chip);
}

Result<std::vector<GpioUse>> gpio_uses(std::string_view lines, std::string_view source) {
    std::vector<GpioUse> uses;
    while (!lines.empty()) {
        const auto end = lines.find('\n');
        const auto line = lines.substr(0, end);
        lines.remove_prefix(end == std::string_view::npos ? lines.size() : end + 1);
        const auto first = line.find('\t');
        const auto second = first == std::string_view::npos ? first : line.find('\t', first + 1);
        long long number = -1;
        if (second != std::string_view::npos) {
            const auto text = line.substr(second + 1);
            const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), number);
            if (ec != std::errc{} || ptr != text.data() + text.size()) {
                number = -1;
            }
        }
        if (number < 0 || first == 0 || second == first + 1) {
            return std::unexpected(
                error(RuleErrorKind::Usage, fmt::format("{}: drivebusd --gpio-lines printed \"{}\", not BUS, CHIP and "
                                                        "LINE apart by tabs (is DRIVEBUSD another program?)",
                                                        source, line)));
        }
        uses.push_back(GpioUse{std::string(line.substr(0, first)),
                               std::string(line.substr(first + 1, second - first - 1)), number});
    }
    if (uses.empty()) {
        return std::unexpected(error(RuleErrorKind::Usage,
                                     fmt::format("{}: no bus has direction = \"gpio\": no GPIO chip to give", source)));
    }
    return uses;
}

std::string device_unit(std::string_view name) {
    std::string out = "dev-drivebus-";
    for (const char c : name) {
        if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || (c == '.' && out.size() > 13)) {
            out += c;
        } else {
            out += fmt::format("\\x{:02x}", static_cast<unsigned char>(c));
        }
    }
    return out + ".device";
}

std::string install_path(const std::optional<PortChoice>& port) {
    return fmt::format("/etc/udev/rules.d/60-drivebus-{}.rules", port ? port->name : std::string("gpio"));
}

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
