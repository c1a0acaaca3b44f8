// SPDX-License-Identifier: Apache-2.0
// What drivebusctl udev-rule's reading (udev_input.cpp) and writing (udev_rule.cpp) of udev's
// properties share: small text helpers, and what it knows of serial devices (udev_device.cpp).
// Internal to client/ctl/.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <string_view>

#include "udev_rule.hpp"

namespace drivebus::ctl::udev::detail {

inline RuleError error(RuleErrorKind kind, std::string message) {
    return RuleError{kind, std::move(message)};
}

// A value as the error shows it: quoted, with control and non-ASCII bytes as \xNN.
inline std::string shown(std::string_view value) {
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

inline std::string_view property(const Properties& p, std::string_view key) {
    const auto it = p.find(key);
    return it == p.end() ? std::string_view{} : std::string_view(it->second);
}

inline std::string_view basename(std::string_view path) {
    const auto slash = path.rfind('/');
    return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

inline bool all_of(std::string_view s, auto predicate) {
    return !s.empty() && std::ranges::all_of(s, predicate);
}

inline bool lower_alnum(char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
}

inline bool hex4(std::string_view s) {
    return s.size() == 4 && std::ranges::all_of(s, [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
}

inline std::string lower(std::string_view s) {
    std::string out(s);
    std::ranges::transform(out, out.begin(), [](char c) { return static_cast<char>(std::tolower(c)); });
    return out;
}

// The driver of the USB serial port: ID_USB_DRIVER (usb_id), else DRIVER (the nearest parent's,
// filled in by drivebusctl when it reads the device itself).
[[nodiscard]] std::string_view usb_driver(const Properties& p);
// "FTDI FT232R (0403:6001)", for the rule's comment.
[[nodiscard]] std::string usb_description(const Properties& p);
[[nodiscard]] bool is_ftdi(const Properties& p);
// An 8250/16550 port: the 8250 core names its ports ttyS<N>; drivebusctl adds the parent's
// driver (serial8250, dw-apb-uart, of_serial, 8250_*) when it reads the device itself.
[[nodiscard]] bool is_8250(const Properties& p);
// The rules file's GOTO label for a port name: "drivebus_rs485_0_end".
[[nodiscard]] std::string label_of(std::string_view name);

}  // namespace drivebus::ctl::udev::detail
