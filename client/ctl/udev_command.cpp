// SPDX-License-Identifier: Apache-2.0
#include "udev_command.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <linux/gpio.h>
#include <sys/ioctl.h>
#include <systemd/sd-device.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

#include "drivebusd_run.hpp"
#include "format.hpp"

namespace drivebus::ctl {
namespace {

using udev::Properties;
using udev::Result;
using udev::RuleError;
using udev::RuleErrorKind;

RuleError error(RuleErrorKind kind, std::string message) {
    return RuleError{kind, std::move(message)};
}

struct DeviceUnref {
    void operator()(sd_device* d) const noexcept { sd_device_unref(d); }
};
using Device = std::unique_ptr<sd_device, DeviceUnref>;

struct EnumeratorUnref {
    void operator()(sd_device_enumerator* e) const noexcept { sd_device_enumerator_unref(e); }
};

Result<std::string> read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        return std::unexpected(error(RuleErrorKind::NotFound, fmt::format("{}: {}", path, std::strerror(errno))));
    }
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

Result<Properties> file_properties(const std::string& path) {
    auto text = read_file(path);
    if (!text) {
        return std::unexpected(text.error());
    }
    auto properties = udev::parse_properties(*text);
    if (!properties) {
        return std::unexpected(error(properties.error().kind, path + ": " + properties.error().message));
    }
    return properties;
}

// The device's properties from udev's database, as `udevadm info --query=property` prints them.
// DRIVER, when the device has none, is the nearest parent's (what udev's DRIVERS== looks at):
// the usb-serial or platform driver of a tty. A device udev has not processed (no udevd, as in
// some containers) has no ID_ properties: a USB adapter is then refused for want of them.
Result<Properties> device_properties(std::string devname) {
    if (devname.find('/') == std::string::npos) {
        devname = "/dev/" + devname;
    }
    sd_device* raw = nullptr;
    const int r = sd_device_new_from_devname(&raw, devname.c_str());
    if (r < 0) {
        return std::unexpected(error(RuleErrorKind::NotFound, fmt::format("{}: {}", devname, std::strerror(-r))));
    }
    const Device device(raw);
    Properties out;
    const char* value = nullptr;
    for (const char* key = sd_device_get_property_first(device.get(), &value); key != nullptr;
         key = sd_device_get_property_next(device.get(), &value)) {
        out[key] = value != nullptr ? value : "";
    }
    if (!out.contains("DRIVER")) {
        // The parents belong to the device: no reference to drop.
        sd_device* child = device.get();
        sd_device* parent = nullptr;
        while (sd_device_get_parent(child, &parent) >= 0) {
            const char* driver = nullptr;
            const char* subsystem = nullptr;
            // Linux 6.5 and later put the serial core's own devices (drivers "port", "ctrl", bus
            // serial-base) between a UART's tty and its hardware: the driver of interest is above.
            const bool serial_core = sd_device_get_subsystem(parent, &subsystem) >= 0 && subsystem != nullptr &&
                                     std::string_view(subsystem) == "serial-base";
            if (!serial_core && sd_device_get_driver(parent, &driver) >= 0 && driver != nullptr) {
                out["DRIVER"] = driver;
                break;
            }
            child = parent;
        }
    }
    return out;
}

// The label of /dev/gpiochipN (GPIO_GET_CHIPINFO_IOCTL), or the error number.
std::expected<std::string, int> chip_label(const std::string& devname) {
    const int fd = ::open(devname.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        return std::unexpected(errno);
    }
    gpiochip_info info{};
    const int r = ::ioctl(fd, GPIO_GET_CHIPINFO_IOCTL, &info);
    const int saved = errno;
    ::close(fd);
    if (r < 0) {
        return std::unexpected(saved);
    }
    return std::string(info.label, strnlen(info.label, sizeof info.label));
}

// A chip named as drivebusd's gpio_chip may name it: gpiochipN, /dev/gpiochipN, N, or a label
// (looked up by opening each chip, as libgpiod does).
Result<udev::GpioChip> live_chip(const std::string& name) {
    std::string devname;
    if (const auto dev = udev::gpio_chip_devname(name)) {
        devname = "/dev/" + *dev;
    } else {
        sd_device_enumerator* raw = nullptr;
        if (const int r = sd_device_enumerator_new(&raw); r < 0) {
            return std::unexpected(error(RuleErrorKind::NotFound, fmt::format("GPIO chips: {}", std::strerror(-r))));
        }
        const std::unique_ptr<sd_device_enumerator, EnumeratorUnref> enumerator(raw);
        sd_device_enumerator_add_match_subsystem(enumerator.get(), "gpio", 1);
        std::string unreadable;
        for (sd_device* d = sd_device_enumerator_get_device_first(enumerator.get()); d != nullptr;
             d = sd_device_enumerator_get_device_next(enumerator.get())) {
            const char* node = nullptr;
            if (sd_device_get_devname(d, &node) < 0 || node == nullptr ||
                !std::string_view(node).starts_with("/dev/gpiochip")) {
                continue;
            }
            const auto label = chip_label(node);
            if (label && *label == name) {
                devname = node;
                break;
            }
            if (!label) {
                unreadable +=
                    fmt::format("{}{} ({})", unreadable.empty() ? "" : ", ", node, std::strerror(label.error()));
            }
        }
        if (devname.empty()) {
            return std::unexpected(
                error(RuleErrorKind::NotFound,
                      fmt::format("no GPIO chip has the label \"{}\"{}", name,
                                  unreadable.empty() ? std::string()
                                                     : " among those it could read; not read: " + unreadable +
                                                           " (run as root, or name the chip gpiochipN)")));
        }
    }
    auto properties = device_properties(devname);
    if (!properties) {
        return std::unexpected(properties.error());
    }
    udev::GpioChip chip;
    chip.properties = std::move(*properties);
    if (const auto label = chip_label(devname)) {
        chip.label = *label;
    }
    return chip;
}

std::string_view basename(std::string_view path) {
    const auto slash = path.rfind('/');
    return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

int fail(const RuleError& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "drivebusctl: udev-rule: %s\n", e.message.c_str());
    switch (e.kind) {
    case RuleErrorKind::Usage: return kExitUsage;
    case RuleErrorKind::Refused: return kExitRejected;
    case RuleErrorKind::NotFound: return kExitUnavailable;
    }
    return kExitUsage;
}

// The GPIO lines of the configuration's buses, as drivebusd reads it: the file, its fragments
// and the profiles, every rule checked (a file drivebusd would refuse gives no rule).
Result<std::vector<udev::GpioUse>> configured_gpio(const UdevRuleArgs& args) {
    std::vector<std::string> command = {"--config", args.config, "--gpio-lines"};
    if (!args.profile_dir.empty()) {
        command.insert(command.end(), {"--profile-dir", args.profile_dir});
    }
    const auto run = run_drivebusd(command);
    if (!run) {
        return std::unexpected(error(RuleErrorKind::NotFound,
                                     run.error() + "; --config is read by drivebusd (install the drivebusd package, "
                                                   "or name it with DRIVEBUSD=PATH)"));
    }
    if (run->exit_code != 0) {
        // drivebusd's own line: "drivebusd: error: drivebusd.toml: bus 'line1': ...".
        std::string said = run->err;
        while (!said.empty() && said.back() == '\n') {
            said.pop_back();
        }
        said = said.substr(said.rfind('\n') + 1);
        if (const auto at = said.find(": error: "); at != std::string::npos) {
            said = said.substr(at + 9);
        }
        return std::unexpected(
            error(RuleErrorKind::Usage,
                  said.empty() ? fmt::format("{}: drivebusd --gpio-lines exited with {}", args.config, run->exit_code)
                               : said));
    }
    return udev::gpio_uses(run->out, args.config);
}

}  // namespace

int run_udev_rule(const UdevRuleArgs& args) {
    if (auto e = udev::check_choice(args.choice)) {
        return fail(*e);
    }
    if (args.device.empty() && args.properties.empty() && args.gpio_chips.empty() && args.config.empty()) {
        return fail(error(RuleErrorKind::Usage, "name a DEVICE, --properties FILE, --gpio-chip CHIP or --config FILE"));
    }

    std::optional<Properties> port;
    std::vector<udev::GpioChip> offline_chips;  // from --properties files
    std::vector<bool> offline_used;
    const auto take = [&](Properties properties, const std::string& from) -> std::optional<RuleError> {
        if (properties["SUBSYSTEM"] == "gpio") {
            offline_chips.push_back(udev::GpioChip{std::move(properties), {}, {}});
            offline_used.push_back(false);
            return std::nullopt;
        }
        if (port) {
            return error(RuleErrorKind::Usage,
                         fmt::format("{}: a second serial port; a rules file names one (run once per adapter)", from));
        }
        port = std::move(properties);
        return std::nullopt;
    };
    for (const auto& file : args.properties) {
        auto properties = file_properties(file);
        if (!properties) {
            return fail(properties.error());
        }
        if (auto e = take(std::move(*properties), file)) {
            return fail(*e);
        }
    }
    if (!args.device.empty()) {
        auto properties = device_properties(args.device);
        if (!properties) {
            return fail(properties.error());
        }
        if (auto e = take(std::move(*properties), args.device)) {
            return fail(*e);
        }
    }

    // The chips asked for, by --gpio-chip and by the configuration's buses.
    std::vector<udev::GpioUse> wanted;
    for (const auto& name : args.gpio_chips) {
        wanted.push_back(udev::GpioUse{{}, name, -1});
    }
    if (!args.config.empty()) {
        auto uses = configured_gpio(args);
        if (!uses) {
            return fail(uses.error());
        }
        wanted.insert(wanted.end(), uses->begin(), uses->end());
    }
    std::vector<udev::GpioChip> chips;
    for (const auto& use : wanted) {
        udev::GpioChip chip;
        if (!offline_chips.empty()) {
            // Offline: the chip must be one of the --properties files, by its device name.
            const auto dev = udev::gpio_chip_devname(use.chip);
            std::size_t i = 0;
            while (i < offline_chips.size() && (!dev || basename(offline_chips[i].properties["DEVNAME"]) != *dev)) {
                ++i;
            }
            if (i == offline_chips.size()) {
                return fail(error(
                    RuleErrorKind::NotFound,
                    fmt::format(
                        "GPIO chip \"{}\": no --properties file is that chip{}", use.chip,
                        dev ? "" : " (a label is looked up only on the machine itself: name the chip gpiochipN)")));
            }
            offline_used[i] = true;
            chip = offline_chips[i];
        } else {
            auto live = live_chip(use.chip);
            if (!live) {
                return fail(live.error());
            }
            chip = std::move(*live);
        }
        if (use.line >= 0) {
            chip.uses.push_back(use);
        }
        chips.push_back(std::move(chip));
    }
    for (std::size_t i = 0; i < offline_chips.size(); ++i) {
        if (!offline_used[i]) {
            chips.push_back(offline_chips[i]);
        }
    }

    auto text = udev::rules_file(port, args.choice, chips);
    if (!text) {
        return fail(text.error());
    }
    std::fwrite(text->data(), 1, text->size(), stdout);
    std::fflush(stdout);
    return kExitOk;
}

}  // namespace drivebus::ctl
