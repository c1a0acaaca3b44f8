// SPDX-License-Identifier: Apache-2.0
// What drivebusctl udev-rule reads before it writes a rule: udev's properties, the name, group
// and unit asked for, the GPIO lines drivebusd reports, and the names it derives.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>

#include "udev_detail.hpp"
#include "udev_rule.hpp"

namespace drivebus::ctl::udev {

using namespace detail;  // NOLINT(google-build-using-namespace): this folder's own helpers

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

}  // namespace drivebus::ctl::udev
