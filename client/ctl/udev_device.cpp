// SPDX-License-Identifier: Apache-2.0
// What drivebusctl udev-rule knows of serial devices: the USB chips and drivers it can name, and
// how it tells an FTDI or an 8250 port.
#include <array>

#include "udev_detail.hpp"

namespace drivebus::ctl::udev::detail {
namespace {

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

}  // namespace

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

}  // namespace drivebus::ctl::udev::detail
