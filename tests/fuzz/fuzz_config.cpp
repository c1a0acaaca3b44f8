// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: drivebusd's configuration reader on arbitrary text, with the shipped profiles.
// A refused file gets one line naming it; an accepted one holds what the reader promises
// (docs/configuration.md): unique valid names, drive addresses inside their profile's range and
// unique on their bus, polled registers readable and unique in their group, values in range.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include "config/config.hpp"
#include "fuzz_support.hpp"
#include "serial/termios.hpp"

using namespace drivebus;
using namespace std::chrono_literals;
using fuzz::check;

namespace {

bool valid_name(std::string_view name) {
    return !name.empty() && std::ranges::all_of(name, [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
}

void check_poll(const config::PollGroup& poll, const Profile& profile) {
    check(valid_name(poll.name), "poll name");
    check(!poll.registers.empty(), "a poll group reads at least one register");
    check(poll.period >= 1ms && poll.period <= 1h, "poll period in 1ms-1h");
    std::set<std::uint16_t> addresses;
    for (const auto& r : poll.registers) {
        check(addresses.insert(r.address).second, "a register twice in one poll group");
        if (const auto* info = profile.find(r.address)) {
            check(readable(info->access), "a polled register is write-only");
            check(info->name == r.name, "a polled register has its profile's name");
        }
    }
    if (poll.indirect) {
        const auto* block = profile.block(3);
        check(block != nullptr, "indirect without a read block");
        check(poll.registers.size() >= block->min_quantity && poll.registers.size() <= block->max_quantity,
              "indirect group within the block's quantity");
    }
}

void check_drive(const config::DriveConfig& drive, const config::BusConfig& bus) {
    check(valid_name(drive.name), "drive name");
    check(drive.profile != nullptr, "a drive without its profile");
    const auto& p = *drive.profile;
    check(drive.address >= p.address_min && drive.address <= p.address_max, "drive address inside the profile's");
    check(drive.address >= 1 && drive.address <= 247, "drive address 1-247");
    check(p.bauds.empty() || std::ranges::find(p.bauds, bus.format.baud) != p.bauds.end(),
          "the bus's baud is one the profile lists");
    check(drive.lease >= 100ms && drive.lease <= 1h, "lease in 100ms-1h");
    check(!drive.keep_alive || (*drive.keep_alive >= 10ms && *drive.keep_alive <= 1h), "keep_alive in 10ms-1h");
    std::set<std::string, std::less<>> polls;
    for (const auto& poll : drive.polls) {
        check(polls.insert(poll.name).second, "two polls of one drive with one name");
        check_poll(poll, p);
    }
}

void check_config(const config::Config& c) {
    check(!c.buses.empty(), "a configuration without a bus");
    check(c.realtime.priority >= 1 && c.realtime.priority <= 99, "priority 1-99");
    check(c.ipc.watch_group != c.ipc.control_group && c.ipc.watch_group != c.ipc.daemon_group &&
              c.ipc.control_group != c.ipc.daemon_group,
          "three different groups");
    std::set<std::string, std::less<>> buses;
    std::set<std::string, std::less<>> devices;
    std::set<std::string, std::less<>> drives;  // unique over every bus
    for (const auto& bus : c.buses) {
        check(valid_name(bus.name) && buses.insert(bus.name).second, "bus names valid and unique");
        check(bus.device.is_absolute() && devices.insert(bus.device.string()).second, "devices absolute and unique");
        check(serial::standard_baud(bus.format.baud), "a standard baud");
        check(bus.format.stop_bits == 1 || bus.format.stop_bits == 2, "stop bits 1 or 2");
        check(bus.response_timeout >= 1ms && bus.response_timeout <= 10s, "response_timeout in 1ms-10s");
        check(bus.retries <= 10, "retries 0-10");
        check(bus.absent_backoff_min >= 1ms && bus.absent_backoff_min <= bus.absent_backoff_max &&
                  bus.absent_backoff_max <= 1h,
              "absent_backoff ordered, in 1ms-1h");
        check(bus.queue_limit >= 1 && bus.queue_limit <= 4096, "queue_limit 1-4096");
        check(bus.direction != config::DirectionMode::Gpio || bus.gpio.has_value(), "gpio direction with its line");
        check(!bus.drives.empty(), "a bus without drives");
        std::set<std::uint8_t> addresses;
        for (const auto& drive : bus.drives) {
            check(drives.insert(drive.name).second, "two drives with one name");
            check(addresses.insert(drive.address).second, "two drives at one address on a bus");
            check_drive(drive, bus);
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    config::LoadOptions options;
    options.profile_dir = DRIVEBUS_FUZZ_PROFILE_DIR;
    const auto parsed = config::parse_config(text, "fuzz.toml", options);
    if (!parsed) {
        fuzz::check_one_line(parsed.error().message, "a configuration error is one line");
        check(parsed.error().message.starts_with("fuzz.toml"), "a configuration error names the file");
        return 0;
    }
    check_config(*parsed);
    return 0;
}
