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

constexpr std::int64_t kAnyInteger = std::numeric_limits<std::int64_t>::max();

constexpr std::array<std::string_view, 3> kParities = {"none", "even", "odd"};
constexpr std::array<std::string_view, 4> kDirections = {"kernel", "gpio", "rts", "none"};
constexpr std::array<std::string_view, 2> kFallbacks = {"rts", "none"};
constexpr std::array<std::string_view, 3> kEchoes = {"off", "on", "auto"};
constexpr std::array<std::string_view, 6> kKernelKeys = {
    "rts_on_send", "rts_after_send", "rx_during_tx", "delay_before_send_ms", "delay_after_send_ms", "kernel_fallback"};
constexpr std::array<std::string_view, 3> kGpioKeys = {"gpio_chip", "gpio_line", "gpio_active_low"};

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

void read_line(Section& s, rtu::LineFormat& format) {
    if (const auto baud = s.integer("baud", -kAnyInteger, kAnyInteger)) {
        if (*baud < 1 || *baud > std::numeric_limits<std::uint32_t>::max() ||
            !serial::standard_baud(static_cast<std::uint32_t>(*baud))) {
            s.fail("baud " + std::to_string(*baud) + " is not a standard rate (e.g. 9600, 19200, 38400, 115200)");
        } else {
            format.baud = static_cast<std::uint32_t>(*baud);
        }
    }
    if (const auto bits = s.integer("data_bits", -kAnyInteger, kAnyInteger); bits && *bits != 8) {
        s.fail("data_bits " + std::to_string(*bits) + " is not 8: Modbus RTU characters carry 8 data bits");
    }
    if (const auto parity = choice(s, "parity", kParities)) {
        static constexpr std::array<rtu::Parity, 3> kValues = {rtu::Parity::None, rtu::Parity::Even, rtu::Parity::Odd};
        format.parity = kValues.at(*parity);
    }
    format.stop_bits = static_cast<std::uint8_t>(s.integer("stop_bits", 1, 2).value_or(1));
}

void read_kernel(Section& s, BusConfig& bus) {
    bus.kernel.rts_on_send = s.boolean("rts_on_send").value_or(bus.kernel.rts_on_send);
    bus.kernel.rts_after_send = s.boolean("rts_after_send").value_or(bus.kernel.rts_after_send);
    bus.kernel.rx_during_tx = s.boolean("rx_during_tx").value_or(bus.kernel.rx_during_tx);
    bus.kernel.delay_before_send_ms = static_cast<std::uint32_t>(s.integer("delay_before_send_ms", 0, 100).value_or(0));
    bus.kernel.delay_after_send_ms = static_cast<std::uint32_t>(s.integer("delay_after_send_ms", 0, 100).value_or(0));
    if (const auto fallback = choice(s, "kernel_fallback", kFallbacks)) {
        bus.kernel_fallback = *fallback == 0 ? DirectionMode::Rts : DirectionMode::None;
    }
}

void read_gpio(Section& s, const toml::table& table, BusConfig& bus) {
    for (const auto key : {"gpio_chip", "gpio_line"}) {
        if (!table.contains(key)) {
            s.fail(std::string("missing key ") + in_quotes(key) + ": direction 'gpio' needs gpio_chip and gpio_line");
            return;
        }
    }
    auto& gpio = bus.gpio.emplace();
    if (auto chip = s.string("gpio_chip")) {
        if (chip->empty()) {
            s.fail("gpio_chip is empty");
        }
        gpio.chip = std::move(*chip);
    }
    gpio.line = static_cast<unsigned>(s.integer("gpio_line", 0, 1023).value_or(0));
    gpio.active_low = s.boolean("gpio_active_low").value_or(false);
}

void read_direction(Section& s, const toml::table& table, BusConfig& bus) {
    const auto index = choice(s, "direction", kDirections);
    if (!table.contains("direction")) {
        bus.direction = DirectionMode::None;
    } else if (!index) {
        return;  // already reported
    } else {
        static constexpr std::array<DirectionMode, 4> kValues = {DirectionMode::Kernel, DirectionMode::Gpio,
                                                                 DirectionMode::Rts, DirectionMode::None};
        bus.direction = kValues.at(*index);
    }
    // A key of another method would be silently ignored: more likely a mistake than intent.
    const auto only_for = [&](std::span<const std::string_view> keys, DirectionMode mode) {
        for (const auto key : keys) {
            if (bus.direction != mode && table.contains(key)) {
                s.fail(std::string(key) + " is only for direction '" + std::string(to_string(mode)) +
                       "', and this bus has direction '" + std::string(to_string(bus.direction)) + "'");
                return;
            }
        }
    };
    only_for(kKernelKeys, DirectionMode::Kernel);
    only_for(kGpioKeys, DirectionMode::Gpio);
    if (bus.direction == DirectionMode::Kernel) {
        read_kernel(s, bus);
    } else if (bus.direction == DirectionMode::Gpio) {
        read_gpio(s, table, bus);
    }
}

void read_absent_backoff(Section& s, const toml::table& table, BusConfig& bus) {
    const auto* node = table.get("absent_backoff");
    if (node == nullptr) {
        return;
    }
    const auto* array = node->as_array();
    const bool pair = array != nullptr && array->size() == 2 && (*array)[0].is_string() && (*array)[1].is_string();
    if (!pair) {
        s.fail("absent_backoff must be two durations [min, max], e.g. [\"1s\", \"30s\"]");
        return;
    }
    const auto least = checked_duration(s, "absent_backoff[0]", (*array)[0].as_string()->get(), 1ms, 1h);
    const auto most = checked_duration(s, "absent_backoff[1]", (*array)[1].as_string()->get(), 1ms, 1h);
    if (!least || !most) {
        return;
    }
    if (*least > *most) {
        s.fail("absent_backoff min " + duration_text(*least) + " is above max " + duration_text(*most));
        return;
    }
    bus.absent_backoff_min = *least;
    bus.absent_backoff_max = *most;
}

void read_timing(Section& s, const toml::table& table, BusConfig& bus) {
    if (const auto echo = choice(s, "echo", kEchoes)) {
        static constexpr std::array<EchoMode, 3> kValues = {EchoMode::Off, EchoMode::On, EchoMode::Auto};
        bus.echo = kValues.at(*echo);
    }
    bus.response_timeout = duration(s, table, "response_timeout", 1ms, 10s).value_or(bus.response_timeout);
    bus.retries = static_cast<unsigned>(s.integer("retries", 0, 10).value_or(bus.retries));
    bus.broadcast_turnaround = duration(s, table, "broadcast_turnaround", 0ns, 10s).value_or(bus.broadcast_turnaround);
    if (const auto guard = duration(s, table, "late_reply_guard", 0ns, 10s)) {
        bus.late_reply_guard = *guard;
    }
    bus.delivery_allowance = duration(s, table, "delivery_allowance", 0ns, 1s).value_or(bus.delivery_allowance);
    read_absent_backoff(s, table, bus);
    bus.queue_limit = static_cast<std::size_t>(s.integer("queue_limit", 1, 4096).value_or(64));
    bus.lock_dir = absolute_path(s, "lock_dir", Need::Optional).value_or("");
}

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
    s.allow_only({"name",
                  "device",
                  "baud",
                  "data_bits",
                  "parity",
                  "stop_bits",
                  "direction",
                  "rts_on_send",
                  "rts_after_send",
                  "rx_during_tx",
                  "delay_before_send_ms",
                  "delay_after_send_ms",
                  "kernel_fallback",
                  "gpio_chip",
                  "gpio_line",
                  "gpio_active_low",
                  "echo",
                  "response_timeout",
                  "retries",
                  "broadcast_turnaround",
                  "late_reply_guard",
                  "delivery_allowance",
                  "absent_backoff",
                  "queue_limit",
                  "lock_dir",
                  "drive"});
    BusConfig bus;
    if (auto name = s.string("name", Need::Required)) {
        if (!valid_name(*name)) {
            s.fail("name " + in_quotes(*name) + " is not made of a-z, 0-9, '_' and '-'");
        } else {
            fits_shm(s, "name", *name, shm::kNameSize, "a bus name");
        }
        bus.name = std::move(*name);
    }
    bus.device = absolute_path(s, "device", Need::Required).value_or("");
    if (!bus.device.empty()) {
        fits_shm(s, "device", bus.device.string(), shm::kDeviceSize, "the bus status's device");
    }
    read_line(s, bus.format);
    read_direction(s, table, bus);
    read_timing(s, table, bus);
    read_drives(s, errors, profiles, drive_names, bus);
    return bus;
}

}  // namespace drivebus::config::detail
