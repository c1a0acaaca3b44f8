// SPDX-License-Identifier: Apache-2.0
// One [[bus]]: the line, its direction control, its timing, then its drives.
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>

#include "drivebus/shm.hpp"
#include "read.hpp"
#include "serial/termios.hpp"

namespace drivebus::config::detail {
namespace {

using namespace std::chrono_literals;

using BusKeys = Keys<BusConfig>;
using GpioKeys = Keys<serial::GpioOptions>;
using serial::KernelRs485Options;

constexpr std::int64_t kAnyInteger = std::numeric_limits<std::int64_t>::max();

// In the order of the enumerators they are read into (rtu::Parity, DirectionMode, EchoMode).
constexpr std::array<std::string_view, 3> kParities = {"none", "even", "odd"};
constexpr std::array<std::string_view, 4> kDirections = {"kernel", "gpio", "rts", "none"};
constexpr std::array<std::string_view, 3> kEchoes = {"off", "on", "auto"};
constexpr std::array<std::string_view, 2> kFallbacks = {"rts", "none"};
static_assert(in_enum_order(kParities, {rtu::Parity::None, rtu::Parity::Even, rtu::Parity::Odd}));
static_assert(in_enum_order(kDirections,
                            {DirectionMode::Kernel, DirectionMode::Gpio, DirectionMode::Rts, DirectionMode::None}));
static_assert(in_enum_order(kEchoes, {EchoMode::Off, EchoMode::On, EchoMode::Auto}));

// Paths are absolute: the daemon does not run from the directory the file was written in.
std::optional<std::filesystem::path> absolute_path(Section& s, std::string_view key, Need need) {
    const auto text = s.string(key, need);
    if (!text) {
        return std::nullopt;
    }
    if (!text->starts_with('/')) {
        s.fail(std::string(key) + " " + in_quotes(*text) + " is not an absolute path");
        return std::nullopt;
    }
    return std::filesystem::path(*text).lexically_normal();
}

void read_name(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& bus) {
    if (auto name = s.string(key.name, key.need)) {
        if (!valid_name(*name)) {
            s.fail("name " + in_quotes(*name) + " is not made of a-z, 0-9, '_' and '-'");
        } else {
            fits_shm(s, key.name, *name, shm::kNameSize, "a bus name");
        }
        bus.name = std::move(*name);
    }
}

void read_device(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& bus) {
    if (auto device = absolute_path(s, key.name, key.need)) {
        fits_shm(s, key.name, device->string(), shm::kDeviceSize, "the bus status's device");
        bus.device = std::move(*device);
    }
}

void read_state_dir(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& bus) {
    if (auto dir = absolute_path(s, key.name, key.need)) {
        bus.state_dir = std::move(*dir);
    }
}

void read_mute_reopen(Section& s, const toml::table& table, const Key<BusConfig>& key, BusConfig& bus) {
    if (const auto* text = table.get_as<std::string>(key.name); text != nullptr && text->get() == "off") {
        bus.mute_reopen = std::nullopt;
        return;
    }
    if (const auto after = duration(s, table, key.name, key.range.shortest, key.range.longest)) {
        bus.mute_reopen = *after;
    }
}

void read_lock_dir(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& bus) {
    if (auto dir = absolute_path(s, key.name, key.need)) {
        bus.lock_dir = std::move(*dir);
    }
}

void read_baud(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& bus) {
    if (const auto baud = s.integer(key.name, -kAnyInteger, kAnyInteger)) {
        if (*baud < 1 || *baud > std::numeric_limits<std::uint32_t>::max() ||
            !serial::standard_baud(static_cast<std::uint32_t>(*baud))) {
            s.fail(std::string(key.name) + " " + std::to_string(*baud) +
                   " is not a standard rate (e.g. 9600, 19200, 38400, 115200)");
        } else {
            bus.format.baud = static_cast<std::uint32_t>(*baud);
        }
    }
}

void read_data_bits(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& /*bus*/) {
    if (const auto bits = s.integer(key.name, -kAnyInteger, kAnyInteger); bits && *bits != key.range.lo) {
        const auto eight = std::to_string(key.range.lo);
        s.fail(std::string(key.name) + " " + std::to_string(*bits) + " is not " + eight +
               ": Modbus RTU characters carry " + eight + " data bits");
    }
}

void read_kernel_fallback(Section& s, const toml::table& /*table*/, const Key<BusConfig>& key, BusConfig& bus) {
    if (const auto fallback = choice(s, key.name, key.range.names)) {
        bus.kernel_fallback = *fallback == 0 ? DirectionMode::Rts : DirectionMode::None;
    }
}

// The keys of direction = "kernel" (TIOCSRS485), into bus.kernel.
constexpr Table<BusConfig, 6> kKernelKeys = {
    BusKeys::boolean<&BusConfig::kernel, &KernelRs485Options::rts_on_send>(
        "rts_on_send", "RTS level while sending (SER_RS485_RTS_ON_SEND)"),
    BusKeys::boolean<&BusConfig::kernel, &KernelRs485Options::rts_after_send>("rts_after_send",
                                                                              "RTS level after sending"),
    BusKeys::boolean<&BusConfig::kernel, &KernelRs485Options::rx_during_tx>("rx_during_tx",
                                                                            "keep the receiver on while sending"),
    BusKeys::integer<&BusConfig::kernel, &KernelRs485Options::delay_before_send_ms>(
        "delay_before_send_ms", 0, 100, "ms between enabling the driver and the first character"),
    BusKeys::integer<&BusConfig::kernel, &KernelRs485Options::delay_after_send_ms>(
        "delay_after_send_ms", 0, 100, "ms between the last character and releasing the driver"),
    BusKeys::custom("kernel_fallback", "string", Need::Optional, names(kFallbacks), read_kernel_fallback,
                    BusKeys::shown<&BusConfig::kernel_fallback>,
                    "what to use when the driver has no RS485 support; absent: fail"),
};

void read_gpio_chip(Section& s, const toml::table& /*table*/, const Key<serial::GpioOptions>& key,
                    serial::GpioOptions& gpio) {
    if (auto chip = s.string(key.name)) {
        if (chip->empty()) {
            s.fail(std::string(key.name) + " is empty");
        }
        gpio.chip = std::move(*chip);
    }
}

// The keys of direction = "gpio", into bus.gpio.
constexpr Table<serial::GpioOptions, 3> kGpioKeys = {
    GpioKeys::custom("gpio_chip", "string", Need::Required, words("not empty"), read_gpio_chip, nullptr,
                     "\"gpiochip0\", \"/dev/gpiochip0\" or a chip label"),
    GpioKeys::integer<&serial::GpioOptions::line>("gpio_line", 0, 1023, "line offset on the chip", Need::Required),
    GpioKeys::boolean<&serial::GpioOptions::active_low>("gpio_active_low", "the enable is active low"),
};

void read_gpio(Section& s, const toml::table& table, BusConfig& bus) {
    std::string needed;
    for (const auto& key : kGpioKeys) {
        if (key.need == Need::Required) {
            needed.append(needed.empty() ? "" : " and ").append(key.name);
        }
    }
    for (const auto& key : kGpioKeys) {
        if (key.need == Need::Required && !table.contains(key.name)) {
            s.fail("missing key " + in_quotes(key.name) + ": direction 'gpio' needs " + needed);
            return;
        }
    }
    read_keys(s, table, kGpioKeys, bus.gpio.emplace());
}

void read_direction(Section& s, const toml::table& table, const Key<BusConfig>& key, BusConfig& bus) {
    const auto index = choice(s, key.name, key.range.names);
    if (!table.contains(key.name)) {
        bus.direction = DirectionMode::None;
    } else if (!index) {
        return;  // already reported
    } else {
        bus.direction = static_cast<DirectionMode>(*index);
    }
    // A key of another method would be silently ignored: more likely a mistake than intent.
    const auto only_for = [&](const auto& keys, DirectionMode mode) {
        for (const auto& other : keys) {
            if (bus.direction != mode && table.contains(other.name)) {
                s.fail(std::string(other.name) + " is only for direction '" + std::string(to_string(mode)) +
                       "', and this bus has direction '" + std::string(to_string(bus.direction)) + "'");
                return;
            }
        }
    };
    only_for(kKernelKeys, DirectionMode::Kernel);
    only_for(kGpioKeys, DirectionMode::Gpio);
    if (bus.direction == DirectionMode::Kernel) {
        read_keys(s, table, kKernelKeys, bus);
    } else if (bus.direction == DirectionMode::Gpio) {
        read_gpio(s, table, bus);
    }
}

void read_absent_backoff(Section& s, const toml::table& table, const Key<BusConfig>& key, BusConfig& bus) {
    const auto* node = table.get(key.name);
    if (node == nullptr) {
        return;
    }
    const auto* array = node->as_array();
    const bool pair = array != nullptr && array->size() == 2 && (*array)[0].is_string() && (*array)[1].is_string();
    if (!pair) {
        s.fail(std::string(key.name) + " must be two durations [min, max], e.g. [\"1s\", \"30s\"]");
        return;
    }
    const auto checked = [&](std::size_t i) {
        return checked_duration(s, std::string(key.name) + "[" + std::to_string(i) + "]",
                                (*array)[i].as_string()->get(), key.range.shortest, key.range.longest);
    };
    const auto least = checked(0);
    const auto most = checked(1);
    if (!least || !most) {
        return;
    }
    if (*least > *most) {
        s.fail(std::string(key.name) + " min " + duration_text(*least) + " is above max " + duration_text(*most));
        return;
    }
    bus.absent_backoff_min = *least;
    bus.absent_backoff_max = *most;
}

std::string shown_absent_backoff(const Key<BusConfig>& key) {
    return "[" + BusKeys::shown<&BusConfig::absent_backoff_min>(key) + ", " +
           BusKeys::shown<&BusConfig::absent_backoff_max>(key) + "]";
}

std::string shown_late_reply_guard(const Key<BusConfig>& /*key*/) {
    return "response_timeout";  // unset: the master waits response_timeout
}

// The order is the order of reading: the line before the direction that drives it.
constexpr Table<BusConfig, 18> kBusKeys = {
    BusKeys::custom("name", "string", Need::Required, words("[a-z0-9_-]+"), read_name, nullptr,
                    "names the bus's services"),
    BusKeys::custom("device", "string", Need::Required, words("absolute path"), read_device, nullptr,
                    "the serial device"),
    BusKeys::custom("baud", "integer", Need::Optional, words("a standard rate"), read_baud,
                    BusKeys::shown<&BusConfig::format, &rtu::LineFormat::baud>, "the line's bit rate"),
    BusKeys::custom("data_bits", "integer", Need::Optional, integers(8, 8), read_data_bits,
                    BusKeys::shown<&BusConfig::format, &rtu::LineFormat::data_bits>,
                    "Modbus RTU characters carry 8 data bits"),
    BusKeys::choice<&BusConfig::format, &rtu::LineFormat::parity>("parity", kParities, "the line's parity"),
    BusKeys::integer<&BusConfig::format, &rtu::LineFormat::stop_bits>("stop_bits", 1, 2, "the line's stop bits"),
    BusKeys::custom("direction", "string", Need::Optional, names(kDirections), read_direction,
                    BusKeys::shown<&BusConfig::direction>,
                    "driver-enable control: the UART driver, a GPIO line, RTS by hand, or the adapter itself"),
    BusKeys::choice<&BusConfig::echo>("echo", kEchoes, "local echo of a 2-wire adapter; auto: the first reply says"),
    BusKeys::duration<&BusConfig::response_timeout>("response_timeout", 1ms, 10s,
                                                    "wait for a reply to begin, from the request leaving the wire"),
    BusKeys::integer<&BusConfig::retries>("retries", 0, 10, "attempts after the first"),
    BusKeys::duration<&BusConfig::broadcast_turnaround>("broadcast_turnaround", 0ns, 10s,
                                                        "silence after a broadcast, for the slaves to act"),
    BusKeys::custom("late_reply_guard", "duration", Need::Optional, durations(0ns, 10s),
                    BusKeys::read_duration<&BusConfig::late_reply_guard>, shown_late_reply_guard,
                    "after a time-out, how long nothing is sent while a late reply may still come"),
    BusKeys::duration<&BusConfig::delivery_allowance>(
        "delivery_allowance", 0ns, 1s, "how long past its wire bound a reply may still be completed by late bytes"),
    BusKeys::custom("absent_backoff", "array of 2 durations", Need::Optional, durations(1ms, 1h, "each"),
                    read_absent_backoff, shown_absent_backoff,
                    "re-probe of an absent drive: first delay, longest delay"),
    BusKeys::integer<&BusConfig::queue_limit>("queue_limit", 1, 4096, "client requests in flight on this bus"),
    BusKeys::custom("lock_dir", "string", Need::Optional, words("absolute path"), read_lock_dir,
                    BusKeys::shown<&BusConfig::lock_dir>, "directory of UUCP lock files; none: no lock file"),
    BusKeys::custom("state_dir", "string", Need::Optional, words("absolute path"), read_state_dir,
                    BusKeys::shown<&BusConfig::state_dir>,
                    "where the bus's lease record is kept (BUS.leases), for the fallbacks across a restart"),
    BusKeys::custom("mute_reopen", "duration or \"off\"", Need::Optional, durations(100ms, 1h), read_mute_reopen,
                    BusKeys::shown<&BusConfig::mute_reopen>,
                    "every drive silent this long while the port is open: the port is reopened"),
};

void read_drives(Section& s, Errors& errors, ProfileCache& profiles, DriveNames& drive_names, BusConfig& bus) {
    const auto drives = s.tables("drive");
    if (drives.empty() && !errors.any()) {
        errors.add("", s.where() + " has no drives ([[bus.drive]])");
        return;
    }
    // The bus status lists the drives clients can find by name or address.
    if (drives.size() > shm::kMaxDrivesPerBus) {
        s.fail(std::to_string(drives.size()) + " drives ([[bus.drive]]), more than the " +
               std::to_string(shm::kMaxDrivesPerBus) + " that a bus status in shared memory lists");
        return;
    }
    std::map<std::uint8_t, std::string> addresses;
    for (std::size_t i = 0; i < drives.size(); ++i) {
        auto drive = read_drive(*drives[i], i, s.where(), bus.format, errors, profiles);
        const auto where =
            s.where() + " drive " + (drive.name.empty() ? "#" + std::to_string(i + 1) : in_quotes(drive.name));
        if (!drive.name.empty()) {
            if (const auto [it, fresh] = drive_names.emplace(drive.name, s.where()); !fresh) {
                errors.add(where, "name " + in_quotes(drive.name) + " is already a drive of " + it->second);
            }
        }
        if (const auto [it, fresh] = addresses.emplace(drive.address, drive.name); !fresh && !errors.any()) {
            errors.add(where,
                       "address " + std::to_string(drive.address) + " is already drive " + in_quotes(it->second));
        }
        bus.drives.push_back(std::move(drive));
    }
}

}  // namespace

BusConfig read_bus(const toml::table& table, std::size_t index, Errors& errors, ProfileCache& profiles,
                   DriveNames& drive_names) {
    Section s(table, entry_name("bus", index), errors);
    if (const auto* name = table.get_as<std::string>("name"); name != nullptr && valid_name(name->get())) {
        s.rename("bus " + in_quotes(name->get()));
    }
    allow_only(s, table, {"drive"}, kBusKeys, kKernelKeys, kGpioKeys);
    BusConfig bus;
    read_keys(s, table, kBusKeys, bus);
    read_drives(s, errors, profiles, drive_names, bus);
    return bus;
}

std::vector<SectionReference> bus_reference() {
    return {described("[[bus]]", kBusKeys), described("direction = \"kernel\"", kKernelKeys),
            described("direction = \"gpio\"", kGpioKeys)};
}

}  // namespace drivebus::config::detail
