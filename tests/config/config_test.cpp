// SPDX-License-Identifier: Apache-2.0
// drivebusd's configuration: the example files, the defaults, and one test per validation rule.
// Profiles are the real ones, found along the default search path (the source tree), except
// where a test needs a profile of its own.
#include "config/config.hpp"
#include "config/reload.hpp"

#include <gtest/gtest.h>

#include "drivebus/shm.hpp"

#include <unistd.h>
#include "one_line_error.hpp"
#include "scratch_dir.hpp"

#include <array>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus::config {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

fs::path example(std::string_view name) {
    return fs::path(DRIVEBUS_TEST_EXAMPLE_DIR) / name;
}

// The smallest configuration that passes every check; each validation test changes one thing.
constexpr std::string_view kValid = R"([[bus]]
name = "line1"
device = "/dev/ttyUSB0"

  [[bus.drive]]
  name = "pump"
  address = 1
  profile = "atv21"

    [[bus.drive.poll]]
    name = "fast"
    registers = ["FD00", "FD01"]
    period = "100ms"
)";

// An Altivar 58 on an 8N1 line, for the rules that need its profile.
constexpr std::string_view kFan = R"([[bus]]
name = "line1"
device = "/dev/ttyUSB0"
parity = "none"

  [[bus.drive]]
  name = "fan"
  address = 2
  profile = "atv58"

    [[bus.drive.poll]]
    registers = ["W450"]
    period = "200ms"
)";

// `text` with the first `from` replaced by `to`.
std::string edited(std::string_view text, std::string_view from, std::string_view to) {
    std::string out(text);
    const auto at = out.find(from);
    if (at == std::string::npos) {
        ADD_FAILURE() << "not in the text: " << from;
        return out;
    }
    return out.replace(at, from.size(), to);
}

// kValid with `lines` added to the bus, the drive or the poll.
std::string with_bus(std::string_view lines) {
    return edited(kValid, "device = \"/dev/ttyUSB0\"\n", "device = \"/dev/ttyUSB0\"\n" + std::string(lines) + "\n");
}
std::string with_drive(std::string_view lines) {
    return edited(kValid, "profile = \"atv21\"\n", "profile = \"atv21\"\n" + std::string(lines) + "\n");
}
std::string with_poll(std::string_view lines) {
    return edited(kValid, "period = \"100ms\"\n", "period = \"100ms\"\n" + std::string(lines) + "\n");
}
// kValid with the poll's registers replaced.
std::string polling(std::string_view registers) {
    return edited(kValid, R"(registers = ["FD00", "FD01"])", "registers = " + std::string(registers));
}

Config parsed(std::string_view text, const LoadOptions& options = {}) {
    auto config = parse_config(text, "test.toml", options);
    if (!config) {
        ADD_FAILURE() << config.error().message;
        return {};
    }
    return *config;
}

// The text is rejected with one line that starts with the file name and holds every one of `parts`.
::testing::AssertionResult rejected(std::string_view text, std::initializer_list<std::string_view> parts,
                                    const LoadOptions& options = {}) {
    const auto config = parse_config(text, "test.toml", options);
    if (config) {
        return ::testing::AssertionFailure() << "parsed without error";
    }
    return drivebus::test::one_line_error(config.error().message, "test.toml", parts);
}

using drivebus::test::ScratchDir;

// A profile with a write-only register, which neither real profile has.
constexpr std::string_view kWriteOnlyProfile = R"(schema = 1
[drive]
type = "wo"
title = "Write-only test drive"
[[register]]
name = "CMD"
address = 0x0010
access = "w"
[[register]]
name = "ST"
address = 0x0011
access = "r"
)";

std::string wo_config(std::string_view registers) {
    return edited(edited(kValid, "\"atv21\"", "\"wo\""), R"(["FD00", "FD01"])", registers);
}

std::vector<std::uint16_t> addresses(const PollGroup& poll) {
    std::vector<std::uint16_t> out;
    for (const auto& r : poll.registers) {
        out.push_back(r.address);
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// The example files

TEST(Examples, Simulator) {
    const auto config = load_config(example("sim.toml"));
    ASSERT_TRUE(config) << config.error().message;
    EXPECT_EQ(config->source, example("sim.toml"));
    EXPECT_EQ(config->realtime.mode, RealtimeMode::Off);
    ASSERT_EQ(config->buses.size(), 1U);
    const auto& bus = config->buses[0];
    EXPECT_EQ(bus.device, "/tmp/ttyDRV");
    EXPECT_EQ(bus.format, (rtu::LineFormat{19200, 8, rtu::Parity::None, 1}));
    EXPECT_EQ(bus.direction, DirectionMode::None);
    ASSERT_EQ(bus.drives.size(), 2U);

    const auto& pump = bus.drives[0];
    EXPECT_EQ(pump.name, "pump");
    EXPECT_EQ(pump.address, 1);
    ASSERT_NE(pump.profile, nullptr);
    EXPECT_EQ(pump.profile->type, "atv21");
    EXPECT_EQ(pump.keep_alive, Duration(1s));
    ASSERT_EQ(pump.polls.size(), 2U);
    EXPECT_TRUE(pump.polls[0].indirect);
    EXPECT_EQ(pump.polls[0].period, Duration(100ms));
    EXPECT_EQ(addresses(pump.polls[0]), (std::vector<std::uint16_t>{0xFD00, 0xFD01, 0xFE03, 0xFE05, 0xFC91}));
    EXPECT_EQ(pump.polls[0].registers[4].name, "FC91");
    EXPECT_FALSE(pump.polls[1].indirect);
    EXPECT_EQ(pump.polls[1].period, Duration(1s));
    EXPECT_EQ(addresses(pump.polls[1]), (std::vector<std::uint16_t>{0xFC90}));

    const auto& fan = bus.drives[1];
    EXPECT_EQ(fan.name, "fan");
    EXPECT_EQ(fan.address, 2);
    ASSERT_NE(fan.profile, nullptr);
    EXPECT_EQ(fan.profile->type, "atv58");
    EXPECT_FALSE(fan.keep_alive.has_value());
    ASSERT_EQ(fan.polls.size(), 1U);
    EXPECT_EQ(fan.polls[0].period, Duration(200ms));
    ASSERT_EQ(fan.polls[0].registers.size(), 10U);
    EXPECT_EQ(fan.polls[0].registers.front().name, "W450");
    EXPECT_EQ(fan.polls[0].registers.front().address, 450);
    EXPECT_EQ(fan.polls[0].registers.back().address, 459);
}

TEST(Examples, RealBoard) {
    const auto config = load_config(example("atv21-atv58.toml"));
    ASSERT_TRUE(config) << config.error().message;
    EXPECT_EQ(config->realtime.mode, RealtimeMode::Required);
    EXPECT_EQ(config->realtime.priority, 60);
    EXPECT_EQ(config->realtime.cpus, (std::vector<int>{1}));
    EXPECT_TRUE(config->realtime.lock_memory);
    ASSERT_EQ(config->buses.size(), 1U);
    const auto& bus = config->buses[0];
    EXPECT_EQ(bus.device, "/dev/drivebus/rs485-0");
    EXPECT_EQ(bus.format, (rtu::LineFormat{19200, 8, rtu::Parity::None, 1}));
    EXPECT_EQ(bus.direction, DirectionMode::Kernel);
    EXPECT_TRUE(bus.kernel.rts_on_send);
    EXPECT_FALSE(bus.kernel.rts_after_send);
    EXPECT_EQ(bus.kernel_fallback, DirectionMode::Rts);
    EXPECT_FALSE(bus.gpio.has_value());
    EXPECT_EQ(bus.lock_dir, "/run/lock");
    ASSERT_EQ(bus.drives.size(), 2U);
    EXPECT_EQ(bus.drives[0].profile->type, "atv21");
    EXPECT_EQ(bus.drives[1].profile->type, "atv58");
}

TEST(Examples, Gpio) {
    const auto config = load_config(example("gpio.toml"));
    ASSERT_TRUE(config) << config.error().message;
    ASSERT_EQ(config->buses.size(), 1U);
    const auto& bus = config->buses[0];
    EXPECT_EQ(bus.direction, DirectionMode::Gpio);
    ASSERT_TRUE(bus.gpio.has_value());
    EXPECT_EQ(bus.gpio->chip, "gpiochip0");
    EXPECT_EQ(bus.gpio->line, 17U);
    EXPECT_FALSE(bus.gpio->active_low);
    EXPECT_EQ(bus.format.parity, rtu::Parity::Even);
    ASSERT_EQ(bus.drives.size(), 1U);
    ASSERT_EQ(bus.drives[0].polls.size(), 1U);
    EXPECT_EQ(bus.drives[0].polls[0].name, "group1");
    EXPECT_TRUE(bus.drives[0].polls[0].indirect);
}

TEST(LoadConfig, MissingFileNamesIt) {
    const auto config = load_config("/nonexistent/drivebusd.toml");
    ASSERT_FALSE(config);
    EXPECT_TRUE(config.error().message.starts_with("/nonexistent/drivebusd.toml: ")) << config.error().message;
}

TEST(LoadConfig, DirectoryIsNotAFile) {
    const auto config = load_config(DRIVEBUS_TEST_EXAMPLE_DIR);
    ASSERT_FALSE(config);
    EXPECT_NE(config.error().message.find("not a regular file"), std::string::npos) << config.error().message;
}

// ---------------------------------------------------------------------------------------------
// Fragments: FILE's directory FILE.d/ (drivebusd.toml: drivebusd.d/), *.toml in name order

constexpr std::string_view kSecondBus = R"([[bus]]
name = "line2"
device = "/dev/ttyUSB1"

  [[bus.drive]]
  name = "fan"
  address = 2
  profile = "atv21"
)";

TEST(Fragments, TheDirectoryIsNamedAfterTheFile) {
    EXPECT_EQ(fragment_directory("/etc/drivebus/drivebusd.toml"), fs::path("/etc/drivebus/drivebusd.d"));
    EXPECT_EQ(fragment_directory("/etc/drivebus/line1.toml"), fs::path("/etc/drivebus/line1.d"));
}

TEST(Fragments, BusesOfFragmentsComeAfterTheMainFileInNameOrder) {
    const test::ScratchDir dir;
    dir.write("drivebusd.toml", kValid);
    fs::create_directory(dir.path() / "drivebusd.d");
    dir.write("drivebusd.d/20-line3.toml", R"([[bus]]
name = "line3"
device = "/dev/ttyUSB2"

  [[bus.drive]]
  name = "mixer"
  address = 3
  profile = "atv21"
)");
    dir.write("drivebusd.d/10-line2.toml", kSecondBus);
    // Not *.toml: an editor's backup and dpkg's old copy are not read.
    dir.write("drivebusd.d/10-line2.toml~", "not toml at all [[");
    dir.write("drivebusd.d/30-old.toml.dpkg-old", "not toml at all [[");
    const auto config = load_config(dir.path() / "drivebusd.toml");
    ASSERT_TRUE(config) << config.error().message;
    ASSERT_EQ(config->buses.size(), 3U);
    EXPECT_EQ(config->buses[0].name, "line1");
    EXPECT_EQ(config->buses[1].name, "line2");
    EXPECT_EQ(config->buses[2].name, "line3");
    ASSERT_EQ(config->fragments.size(), 2U);
    EXPECT_EQ(config->fragments[0].filename(), "10-line2.toml");
    EXPECT_EQ(config->fragments[1].filename(), "20-line3.toml");
}

TEST(Fragments, AnErrorNamesTheFragmentItIsIn) {
    const test::ScratchDir dir;
    dir.write("drivebusd.toml", kValid);
    fs::create_directory(dir.path() / "drivebusd.d");
    const auto fragment = (dir.path() / "drivebusd.d" / "10-line2.toml").string();
    std::string bad(kSecondBus);
    bad.replace(bad.find("address = 2"), 11, "address = 300");
    dir.write("drivebusd.d/10-line2.toml", bad);
    auto config = load_config(dir.path() / "drivebusd.toml");
    ASSERT_FALSE(config);
    EXPECT_TRUE(config.error().message.starts_with(fragment + ": bus 'line2'")) << config.error().message;
    EXPECT_NE(config.error().message.find("300"), std::string::npos) << config.error().message;

    // A bus name taken in the main file: the fragment that takes it again is named.
    std::string same(kSecondBus);
    same.replace(same.find("line2"), 5, "line1");
    dir.write("drivebusd.d/10-line2.toml", same);
    config = load_config(dir.path() / "drivebusd.toml");
    ASSERT_FALSE(config);
    EXPECT_TRUE(config.error().message.starts_with(fragment + ": bus 'line1': name 'line1' is already another bus"))
        << config.error().message;

    // A syntax error.
    dir.write("drivebusd.d/10-line2.toml", "[[bus]\n");
    config = load_config(dir.path() / "drivebusd.toml");
    ASSERT_FALSE(config);
    EXPECT_TRUE(config.error().message.starts_with(fragment + ": line 1")) << config.error().message;
}

TEST(Fragments, RealtimeAndIpcBelongToTheMainFile) {
    const std::array files = {ConfigText{"drivebusd.toml", std::string(kValid)},
                              ConfigText{"drivebusd.d/ipc.toml", "[ipc]\nmax_clients = 4\n"}};
    const auto config = parse_config(files);
    ASSERT_FALSE(config);
    EXPECT_TRUE(config.error().message.starts_with("drivebusd.d/ipc.toml: ")) << config.error().message;
    EXPECT_NE(config.error().message.find("ipc"), std::string::npos) << config.error().message;
}

TEST(Fragments, AMainFileWithNoBusIsValidWhenAFragmentHasOne) {
    const std::array files = {ConfigText{"drivebusd.toml", "[realtime]\nmode = \"off\"\n"},
                              ConfigText{"drivebusd.d/line1.toml", std::string(kValid)}};
    const auto config = parse_config(files);
    ASSERT_TRUE(config) << config.error().message;
    EXPECT_EQ(config->buses.size(), 1U);
    EXPECT_EQ(config->realtime.mode, RealtimeMode::Off);
}

TEST(Fragments, ABusSettingsTextChangesWithItsSettingsAndNotWithItsPlace) {
    const auto alone = parsed(kValid);
    const std::array moved = {ConfigText{"drivebusd.toml", "# buses in drivebusd.d/\n"},
                              ConfigText{"drivebusd.d/line1.toml", "# line 1\n\n" + std::string(kValid)}};
    const auto elsewhere = parse_config(moved);
    ASSERT_TRUE(elsewhere) << elsewhere.error().message;
    EXPECT_FALSE(alone.buses[0].settings.empty());
    EXPECT_EQ(alone.buses[0].settings, elsewhere->buses[0].settings);
    std::string faster(kValid);
    faster.replace(faster.find("100ms"), 5, "50ms");
    EXPECT_NE(parsed(faster).buses[0].settings, alone.buses[0].settings);
}

// ---------------------------------------------------------------------------------------------
// What a reload does with a new configuration

TEST(PlanReload, KeepsWhatIsUnchangedAndRestartsStopsOrStartsTheRest) {
    const std::array running_files = {ConfigText{"drivebusd.toml", std::string(kValid)},
                                      ConfigText{"drivebusd.d/line2.toml", std::string(kSecondBus)}};
    const auto running = parse_config(running_files);
    ASSERT_TRUE(running) << running.error().message;

    auto same = plan_reload(*running, *running);
    ASSERT_TRUE(same);
    EXPECT_TRUE(same->nothing());
    EXPECT_EQ(describe(*same), "no change");

    // line1 polls faster, line2 is gone, line3 is new.
    std::string faster(kValid);
    faster.replace(faster.find("100ms"), 5, "50ms");
    const std::array next_files = {ConfigText{"drivebusd.toml", faster}, ConfigText{"drivebusd.d/line3.toml", R"([[bus]]
name = "line3"
device = "/dev/ttyUSB2"
  [[bus.drive]]
  name = "mixer"
  address = 3
  profile = "atv21"
)"}};
    const auto next = parse_config(next_files);
    ASSERT_TRUE(next) << next.error().message;
    const auto plan = plan_reload(*running, *next);
    ASSERT_TRUE(plan);
    EXPECT_EQ(plan->keep, std::vector<std::string>{});
    EXPECT_EQ(plan->restart, std::vector<std::string>{"line1"});
    EXPECT_EQ(plan->stop, std::vector<std::string>{"line2"});
    EXPECT_EQ(plan->start, std::vector<std::string>{"line3"});
    EXPECT_EQ(describe(*plan), "restarted (settings changed) line1; stopped line2; started line3");

    // The same buses with only a comment and the order of keys changed: nothing restarts.
    const std::array reordered = {ConfigText{"drivebusd.toml", "# edited\n" + std::string(kValid)},
                                  ConfigText{"drivebusd.d/line2.toml", R"([[bus]]
device = "/dev/ttyUSB1"
name = "line2"

  [[bus.drive]]
  profile = "atv21"
  address = 2
  name = "fan"
)"}};
    const auto edited = parse_config(reordered);
    ASSERT_TRUE(edited) << edited.error().message;
    const auto untouched = plan_reload(*running, *edited);
    ASSERT_TRUE(untouched);
    EXPECT_TRUE(untouched->nothing()) << describe(*untouched);
    EXPECT_EQ(untouched->keep, (std::vector<std::string>{"line1", "line2"}));
}

TEST(PlanReload, RealtimeRestartsEveryBusAndIpcNeedsARestartOfTheDaemon) {
    const auto running = parsed(kValid);
    const auto realtime = parsed("[realtime]\npriority = 70\n" + std::string(kValid));
    const auto plan = plan_reload(running, realtime);
    ASSERT_TRUE(plan);
    EXPECT_TRUE(plan->realtime_changed);
    EXPECT_EQ(plan->restart, std::vector<std::string>{"line1"});
    EXPECT_EQ(describe(*plan), "restarted ([realtime] changed) line1");

    const auto ipc = parsed("[ipc]\nmax_clients = 4\n" + std::string(kValid));
    const auto refused = plan_reload(running, ipc);
    ASSERT_FALSE(refused);
    EXPECT_TRUE(refused.error().starts_with("[ipc] changed")) << refused.error();
}

// ---------------------------------------------------------------------------------------------
// Defaults and what is read

TEST(Defaults, AppliedWhenKeysAreAbsent) {
    const auto config = parsed(kValid);
    EXPECT_EQ(config.source, "test.toml");
    EXPECT_EQ(config.realtime.mode, RealtimeMode::BestEffort);
    EXPECT_EQ(config.realtime.priority, 50);
    EXPECT_TRUE(config.realtime.cpus.empty());
    EXPECT_TRUE(config.realtime.lock_memory);
    EXPECT_EQ(config.realtime.send_spin.count(), 0);
    ASSERT_EQ(config.buses.size(), 1U);
    const auto& bus = config.buses[0];
    EXPECT_EQ(bus.name, "line1");
    EXPECT_EQ(bus.format, (rtu::LineFormat{19200, 8, rtu::Parity::Even, 1}));
    EXPECT_EQ(bus.direction, DirectionMode::None);
    EXPECT_FALSE(bus.gpio.has_value());
    EXPECT_FALSE(bus.kernel_fallback.has_value());
    EXPECT_EQ(bus.echo, EchoMode::Off);
    EXPECT_EQ(bus.response_timeout, Duration(100ms));
    EXPECT_EQ(bus.retries, 2U);
    EXPECT_EQ(bus.broadcast_turnaround, Duration(10ms));
    EXPECT_EQ(bus.delivery_allowance, Duration(50ms));
    EXPECT_EQ(bus.absent_backoff_min, Duration(1s));
    EXPECT_EQ(bus.absent_backoff_max, Duration(30s));
    EXPECT_EQ(bus.queue_limit, 64U);
    EXPECT_TRUE(bus.lock_dir.empty());
    ASSERT_EQ(bus.drives.size(), 1U);
    EXPECT_FALSE(bus.drives[0].keep_alive.has_value());
    ASSERT_EQ(bus.drives[0].polls.size(), 1U);
    EXPECT_FALSE(bus.drives[0].polls[0].indirect);
}

TEST(Defaults, KernelOptionsWhenOnlyDirectionIsGiven) {
    const auto bus = parsed(with_bus(R"(direction = "kernel")")).buses.at(0);
    EXPECT_EQ(bus.direction, DirectionMode::Kernel);
    EXPECT_TRUE(bus.kernel.rts_on_send);
    EXPECT_FALSE(bus.kernel.rts_after_send);
    EXPECT_FALSE(bus.kernel.rx_during_tx);
    EXPECT_EQ(bus.kernel.delay_before_send_ms, 0U);
    EXPECT_EQ(bus.kernel.delay_after_send_ms, 0U);
    EXPECT_FALSE(bus.kernel_fallback.has_value());  // fail when the driver lacks RS485
}

TEST(Defaults, UnnamedPollsAreNumbered) {
    const auto text = with_poll(R"(
    [[bus.drive.poll]]
    registers = ["FC90"]
    period = "1s")");
    const auto polls = parsed(edited(text, "name = \"fast\"\n", "")).buses.at(0).drives.at(0).polls;
    ASSERT_EQ(polls.size(), 2U);
    EXPECT_EQ(polls[0].name, "group1");
    EXPECT_EQ(polls[1].name, "group2");
}

TEST(Read, EveryBusKey) {
    const auto bus = parsed(with_bus(R"(baud = 9600
data_bits = 8
parity = "odd"
stop_bits = 2
direction = "kernel"
rts_on_send = false
rts_after_send = true
rx_during_tx = true
delay_before_send_ms = 3
delay_after_send_ms = 100
kernel_fallback = "none"
echo = "auto"
response_timeout = "250ms"
retries = 0
broadcast_turnaround = "0ms"
delivery_allowance = "0ms"
absent_backoff = ["500ms", "500ms"]
queue_limit = 4096
lock_dir = "/var/lock/")"))
                         .buses.at(0);
    EXPECT_EQ(bus.format, (rtu::LineFormat{9600, 8, rtu::Parity::Odd, 2}));
    EXPECT_FALSE(bus.kernel.rts_on_send);
    EXPECT_TRUE(bus.kernel.rts_after_send);
    EXPECT_TRUE(bus.kernel.rx_during_tx);
    EXPECT_EQ(bus.kernel.delay_before_send_ms, 3U);
    EXPECT_EQ(bus.kernel.delay_after_send_ms, 100U);
    EXPECT_EQ(bus.kernel_fallback, DirectionMode::None);
    EXPECT_EQ(bus.echo, EchoMode::Auto);
    EXPECT_EQ(bus.response_timeout, Duration(250ms));
    EXPECT_EQ(bus.retries, 0U);
    EXPECT_EQ(bus.broadcast_turnaround, Duration(0));
    EXPECT_EQ(bus.delivery_allowance, Duration(0));
    EXPECT_EQ(bus.absent_backoff_min, Duration(500ms));
    EXPECT_EQ(bus.absent_backoff_max, Duration(500ms));
    EXPECT_EQ(bus.queue_limit, 4096U);
    EXPECT_EQ(bus.lock_dir, "/var/lock/");
}

TEST(Read, GpioActiveLow) {
    const auto bus = parsed(with_bus(R"(direction = "gpio"
gpio_chip = "/dev/gpiochip2"
gpio_line = 1023
gpio_active_low = true)"))
                         .buses.at(0);
    ASSERT_TRUE(bus.gpio.has_value());
    EXPECT_EQ(bus.gpio->chip, "/dev/gpiochip2");
    EXPECT_EQ(bus.gpio->line, 1023U);
    EXPECT_TRUE(bus.gpio->active_low);
}

TEST(Read, DurationUnits) {
    EXPECT_EQ(parsed(with_bus(R"(response_timeout = "1000000ns")")).buses.at(0).response_timeout, Duration(1ms));
    EXPECT_EQ(parsed(with_bus(R"(response_timeout = "1500us")")).buses.at(0).response_timeout, Duration(1500us));
    EXPECT_EQ(parsed(with_bus(R"(response_timeout = "10s")")).buses.at(0).response_timeout, Duration(10s));
}

TEST(Read, RegistersByNameAnyCaseOrNumber) {
    const auto poll = parsed(polling(R"(["fd00", "0xFD01", "65027", 65029])")).buses.at(0).drives.at(0).polls.at(0);
    ASSERT_EQ(poll.registers.size(), 4U);
    // A number the profile names takes the profile's name.
    EXPECT_EQ(poll.registers[0].name, "FD00");
    EXPECT_EQ(poll.registers[1].name, "FD01");
    EXPECT_EQ(poll.registers[2].name, "FE03");
    EXPECT_EQ(poll.registers[3].name, "FE05");
    EXPECT_EQ(addresses(poll), (std::vector<std::uint16_t>{0xFD00, 0xFD01, 0xFE03, 0xFE05}));
}

TEST(Read, NumberTheProfileDoesNotNameIsKept) {
    const auto poll = parsed(edited(kFan, R"(["W450"])", R"(["0x0200", 513])")).buses.at(0).drives.at(0).polls.at(0);
    ASSERT_EQ(poll.registers.size(), 2U);
    EXPECT_EQ(poll.registers[0].name, "0x0200");
    EXPECT_EQ(poll.registers[0].address, 0x0200);
    EXPECT_EQ(poll.registers[1].name, "0x0201");
}

// The scheduler splits a group into reads the drive accepts (ATV21: one register per FC03).
TEST(Read, PlainGroupAboveReadHoldingMaxIsFine) {
    const auto poll =
        parsed(polling(R"(["FD00", "FD01", "FE03", "FE05", "FC90", "FC91"])")).buses.at(0).drives.at(0).polls.at(0);
    EXPECT_EQ(poll.registers.size(), 6U);
}

TEST(Read, DrivesOfOneTypeShareTheProfile) {
    const auto text = std::string(kValid) + R"(
  [[bus.drive]]
  name = "pump2"
  address = 2
  profile = "atv21"
)";
    const auto config = parsed(text);
    const auto& drives = config.buses.at(0).drives;
    ASSERT_EQ(drives.size(), 2U);
    EXPECT_EQ(drives[0].profile, drives[1].profile);
    EXPECT_TRUE(drives[1].polls.empty());
}

TEST(Read, KeepAliveOffIsNone) {
    EXPECT_FALSE(parsed(with_drive(R"(keep_alive = "off")")).buses.at(0).drives.at(0).keep_alive.has_value());
    EXPECT_EQ(parsed(with_drive(R"(keep_alive = "10ms")")).buses.at(0).drives.at(0).keep_alive, Duration(10ms));
}

TEST(Read, ProfileDirectoryOption) {
    const ScratchDir dir;
    dir.write("wo.toml", kWriteOnlyProfile);
    const auto config = parsed(wo_config(R"(["ST"])"), LoadOptions{dir.path()});
    EXPECT_EQ(config.buses.at(0).drives.at(0).profile->type, "wo");
}

TEST(Read, ToString) {
    EXPECT_EQ(to_string(DirectionMode::Kernel), "kernel");
    EXPECT_EQ(to_string(DirectionMode::Gpio), "gpio");
    EXPECT_EQ(to_string(DirectionMode::Rts), "rts");
    EXPECT_EQ(to_string(DirectionMode::None), "none");
    EXPECT_EQ(to_string(EchoMode::Off), "off");
    EXPECT_EQ(to_string(EchoMode::On), "on");
    EXPECT_EQ(to_string(EchoMode::Auto), "auto");
}

// ---------------------------------------------------------------------------------------------
// Validation: the file as a whole

TEST(Reject, TomlSyntaxWithLine) {
    EXPECT_TRUE(rejected("[[bus]]\nname = \n", {"line 2"}));
}

TEST(Reject, NoBus) {
    EXPECT_TRUE(rejected("", {"no [[bus]]"}));
    EXPECT_TRUE(rejected("[realtime]\nmode = \"off\"\n", {"no [[bus]]"}));
}

TEST(Reject, BusWrittenAsTable) {
    EXPECT_TRUE(rejected("[bus]\nname = \"line1\"\n", {"bus must be an array of tables"}));
}

TEST(Reject, UnknownKeyAtTheTop) {
    EXPECT_TRUE(rejected(std::string("buses = 1\n") + std::string(kValid), {"unknown key 'buses'"}));
}

TEST(Reject, UnknownKeyInRealtime) {
    EXPECT_TRUE(rejected("[realtime]\nprio = 5\n" + std::string(kValid), {"realtime: ", "unknown key 'prio'"}));
}

TEST(Reject, UnknownKeyInBusLikeBaudrate) {
    EXPECT_TRUE(rejected(with_bus("baudrate = 19200"), {"bus 'line1': ", "unknown key 'baudrate'"}));
}

TEST(Reject, UnknownKeyInDrive) {
    EXPECT_TRUE(rejected(with_drive("adress = 2"), {"bus 'line1' drive 'pump': ", "unknown key 'adress'"}));
}

TEST(Reject, UnknownKeyInPoll) {
    EXPECT_TRUE(
        rejected(with_poll("interval = \"1s\""), {"bus 'line1' drive 'pump' poll 'fast': ", "unknown key 'interval'"}));
}

TEST(Reject, WrongTypes) {
    EXPECT_TRUE(rejected(with_bus(R"(baud = "19200")"), {"bus 'line1'", "baud must be an integer, not a string"}));
    EXPECT_TRUE(rejected(with_bus("retries = true"), {"retries must be an integer, not a boolean"}));
    EXPECT_TRUE(rejected(with_bus("direction = 1"), {"direction must be a string"}));
    EXPECT_TRUE(rejected(edited(kValid, "address = 1", R"(address = "1")"),
                         {"drive 'pump'", "address must be an integer, not a string"}));
    EXPECT_TRUE(rejected(with_poll("indirect = 1"), {"poll 'fast'", "indirect must be a boolean"}));
    EXPECT_TRUE(rejected("realtime = 1\n" + std::string(kValid), {"realtime must be a table"}));
    EXPECT_TRUE(rejected(edited(kValid, R"(name = "line1")", "name = 1"), {"bus #1", "name must be a string"}));
}

TEST(Reject, ValidBaseParses) {
    EXPECT_TRUE(parse_config(kValid, "test.toml").has_value());
    EXPECT_TRUE(parse_config(kFan, "test.toml").has_value());
}

// ---------------------------------------------------------------------------------------------
// Validation: [realtime]

TEST(Reject, RealtimeMode) {
    EXPECT_TRUE(rejected("[realtime]\nmode = \"on\"\n" + std::string(kValid),
                         {"realtime: mode 'on' is not one of off, best-effort, required"}));
}

TEST(Reject, RealtimePriorityOutside1To99) {
    EXPECT_TRUE(rejected("[realtime]\npriority = 0\n" + std::string(kValid), {"realtime: priority 0 is below 1"}));
    EXPECT_TRUE(rejected("[realtime]\npriority = 100\n" + std::string(kValid), {"realtime: priority 100 is above 99"}));
}

TEST(Reject, RealtimeSendSpinOutside0To1ms) {
    EXPECT_TRUE(
        rejected("[realtime]\nsend_spin = \"2ms\"\n" + std::string(kValid), {"realtime: send_spin 2ms is above 1ms"}));
    EXPECT_TRUE(rejected("[realtime]\nsend_spin = 100\n" + std::string(kValid), {"realtime: send_spin", "unit"}));
}

TEST(Config, RealtimeSendSpin) {
    const auto config = parsed("[realtime]\nsend_spin = \"150us\"\n" + std::string(kValid));
    EXPECT_EQ(config.realtime.send_spin, std::chrono::microseconds(150));
}

TEST(Reject, RealtimeCpusNegative) {
    EXPECT_TRUE(rejected("[realtime]\ncpus = [1, -1]\n" + std::string(kValid), {"realtime: cpus[1] -1 is below 0"}));
}

TEST(Reject, RealtimeCpusDuplicated) {
    EXPECT_TRUE(
        rejected("[realtime]\ncpus = [2, 3, 2]\n" + std::string(kValid), {"realtime: cpus[2] 2 is listed twice"}));
}

// ---------------------------------------------------------------------------------------------
// Validation: [[bus]]

TEST(Reject, BusWithoutName) {
    EXPECT_TRUE(rejected(edited(kValid, "name = \"line1\"\n", ""), {"bus #1: missing key 'name'"}));
}

TEST(Reject, BusNameCharacters) {
    EXPECT_TRUE(rejected(edited(kValid, R"("line1")", R"("Line 1")"), {"bus #1", "name 'Line 1' is not made of"}));
}

TEST(Reject, BusWithoutDevice) {
    EXPECT_TRUE(rejected(edited(kValid, "device = \"/dev/ttyUSB0\"\n", ""), {"bus 'line1': missing key 'device'"}));
}

TEST(Reject, RelativeDevice) {
    EXPECT_TRUE(rejected(edited(kValid, "/dev/ttyUSB0", "ttyUSB0"), {"bus 'line1'", "device 'ttyUSB0'", "absolute"}));
}

TEST(Reject, NonStandardBaud) {
    EXPECT_TRUE(rejected(with_bus("baud = 14400"), {"bus 'line1': baud 14400 is not a standard rate"}));
    EXPECT_TRUE(rejected(with_bus("baud = 0"), {"bus 'line1': baud 0 is not a standard rate"}));
}

TEST(Reject, DataBitsOtherThan8) {
    EXPECT_TRUE(rejected(with_bus("data_bits = 7"), {"bus 'line1': data_bits 7 is not 8"}));
}

TEST(Reject, Parity) {
    EXPECT_TRUE(rejected(with_bus(R"(parity = "mark")"), {"bus 'line1': parity 'mark' is not one of none, even, odd"}));
}

TEST(Reject, StopBits) {
    EXPECT_TRUE(rejected(with_bus("stop_bits = 3"), {"bus 'line1': stop_bits 3 is above 2"}));
}

TEST(Reject, Direction) {
    EXPECT_TRUE(rejected(with_bus(R"(direction = "auto")"), {"bus 'line1': direction 'auto' is not one of"}));
}

TEST(Reject, KernelKeysWithAnotherDirection) {
    for (const std::string key : {"rts_on_send = true", "rts_after_send = false", "rx_during_tx = false",
                                  "delay_before_send_ms = 0", "delay_after_send_ms = 0", "kernel_fallback = \"rts\""}) {
        const auto name = key.substr(0, key.find(' '));
        SCOPED_TRACE(name);
        EXPECT_TRUE(rejected(with_bus("direction = \"rts\"\n" + key),
                             {"bus 'line1': ", name, "only for direction 'kernel'", "direction 'rts'"}));
        // Without a direction the bus has none: the key is still out of place.
        EXPECT_TRUE(rejected(with_bus(key), {"bus 'line1': ", name, "direction 'none'"}));
    }
}

TEST(Reject, GpioKeysWithAnotherDirection) {
    EXPECT_TRUE(rejected(with_bus("direction = \"kernel\"\ngpio_line = 4"),
                         {"bus 'line1': gpio_line is only for direction 'gpio'"}));
}

TEST(Reject, GpioWithoutChip) {
    EXPECT_TRUE(rejected(with_bus("direction = \"gpio\"\ngpio_line = 17"), {"bus 'line1': ", "'gpio_chip'"}));
}

TEST(Reject, GpioWithoutLine) {
    EXPECT_TRUE(
        rejected(with_bus("direction = \"gpio\"\ngpio_chip = \"gpiochip0\""), {"bus 'line1': ", "'gpio_line'"}));
}

TEST(Reject, GpioLineOutOfRange) {
    EXPECT_TRUE(rejected(with_bus("direction = \"gpio\"\ngpio_chip = \"gpiochip0\"\ngpio_line = 1024"),
                         {"bus 'line1': gpio_line 1024 is above 1023"}));
}

TEST(Reject, KernelDelayOutOfRange) {
    EXPECT_TRUE(rejected(with_bus("direction = \"kernel\"\ndelay_before_send_ms = 101"),
                         {"bus 'line1': delay_before_send_ms 101 is above 100"}));
}

TEST(Reject, KernelFallback) {
    EXPECT_TRUE(rejected(with_bus("direction = \"kernel\"\nkernel_fallback = \"gpio\""),
                         {"bus 'line1': kernel_fallback 'gpio' is not one of rts, none"}));
}

TEST(Reject, Echo) {
    EXPECT_TRUE(rejected(with_bus(R"(echo = "yes")"), {"bus 'line1': echo 'yes' is not one of off, on, auto"}));
}

TEST(Reject, DurationWithoutUnit) {
    EXPECT_TRUE(rejected(with_bus(R"(response_timeout = "100")"), {"bus 'line1': response_timeout '100' has no unit"}));
    EXPECT_TRUE(
        rejected(with_bus("response_timeout = 100"), {"bus 'line1': response_timeout must be a string with a unit"}));
}

// The one duration grammar (lib/duration): a fraction and a blank before the unit are fine.
TEST(Config, DurationsTakeAFractionAndMinutes) {
    EXPECT_EQ(parsed(with_bus(R"(response_timeout = "1.5s")")).buses.at(0).response_timeout,
              std::chrono::milliseconds(1500));
    EXPECT_EQ(parsed(with_bus(R"(response_timeout = "250 ms")")).buses.at(0).response_timeout,
              std::chrono::milliseconds(250));
    EXPECT_TRUE(rejected(with_bus(R"(response_timeout = "1min")"), {"response_timeout 1min is above 10s"}));
}

TEST(Reject, DurationBadText) {
    for (const char* text : {"100h", "1.5.2s", "-1ms", "ms", "1e3ms", "0x10ms", ""}) {
        SCOPED_TRACE(text);
        EXPECT_TRUE(rejected(with_bus("response_timeout = \"" + std::string(text) + "\""),
                             {"bus 'line1': response_timeout", "is not a duration"}));
    }
    EXPECT_TRUE(rejected(with_bus(R"(response_timeout = "99999999999999999999s")"), {"is too large"}));
    EXPECT_TRUE(rejected(with_bus(R"(response_timeout = "9999999999999s")"), {"is too large"}));
}

TEST(Reject, ResponseTimeoutOutside1msTo10s) {
    EXPECT_TRUE(rejected(with_bus(R"(response_timeout = "999us")"), {"response_timeout 999us is below 1ms"}));
    EXPECT_TRUE(rejected(with_bus(R"(response_timeout = "11s")"), {"response_timeout 11s is above 10s"}));
}

TEST(Reject, BroadcastTurnaroundAbove10s) {
    EXPECT_TRUE(rejected(with_bus(R"(broadcast_turnaround = "10001ms")"),
                         {"bus 'line1': broadcast_turnaround 10001ms is above 10s"}));
}

TEST(Reject, Retries) {
    EXPECT_TRUE(rejected(with_bus("retries = 11"), {"bus 'line1': retries 11 is above 10"}));
    EXPECT_TRUE(rejected(with_bus("retries = -1"), {"bus 'line1': retries -1 is below 0"}));
}

TEST(Reject, QueueLimit) {
    EXPECT_TRUE(rejected(with_bus("queue_limit = 0"), {"bus 'line1': queue_limit 0 is below 1"}));
    EXPECT_TRUE(rejected(with_bus("queue_limit = 4097"), {"bus 'line1': queue_limit 4097 is above 4096"}));
}

TEST(Reject, AbsentBackoffMinAboveMax) {
    EXPECT_TRUE(rejected(with_bus(R"(absent_backoff = ["30s", "1s"])"),
                         {"bus 'line1': absent_backoff min 30s is above max 1s"}));
}

TEST(Reject, AbsentBackoffShape) {
    EXPECT_TRUE(
        rejected(with_bus(R"(absent_backoff = ["1s"])"), {"bus 'line1': absent_backoff must be two durations"}));
    EXPECT_TRUE(rejected(with_bus(R"(absent_backoff = "1s")"), {"absent_backoff must be two durations"}));
    EXPECT_TRUE(rejected(with_bus(R"(absent_backoff = ["1s", "30"])"), {"absent_backoff[1] '30' has no unit"}));
}

TEST(Reject, RelativeLockDir) {
    EXPECT_TRUE(
        rejected(with_bus(R"(lock_dir = "run/lock")"), {"bus 'line1': lock_dir 'run/lock' is not an absolute"}));
}

TEST(Reject, BusWithoutDrives) {
    const auto text = "[[bus]]\nname = \"x\"\ndevice = \"/dev/ttyS0\"\n";
    EXPECT_TRUE(rejected(text, {"test.toml: bus 'x' has no drives"}));
}

TEST(Reject, DuplicateBusNames) {
    const auto text = std::string(kValid) + edited(edited(kValid, "ttyUSB0", "ttyUSB1"), "pump", "pump2");
    EXPECT_TRUE(rejected(text, {"bus 'line1': name 'line1' is already another bus"}));
}

TEST(Reject, DuplicateBusDevices) {
    const auto text = std::string(kValid) + edited(edited(kValid, "line1", "line2"), "pump", "pump2");
    EXPECT_TRUE(rejected(text, {"bus 'line2': device '/dev/ttyUSB0' is already bus 'line1'"}));
    // The same device written differently is the same device.
    const auto other =
        std::string(kValid) + edited(edited(edited(kValid, "line1", "line2"), "pump", "pump2"), "/dev/", "/dev//./");
    EXPECT_TRUE(rejected(other, {"bus 'line2': device", "is already bus 'line1'"}));
}

// ---------------------------------------------------------------------------------------------
// Validation: [[bus.drive]]

TEST(Reject, DriveMissingKeys) {
    EXPECT_TRUE(rejected(edited(kValid, "name = \"pump\"\n", ""), {"bus 'line1' drive #1: missing key 'name'"}));
    EXPECT_TRUE(rejected(edited(kValid, "address = 1\n", ""), {"bus 'line1' drive 'pump': missing key 'address'"}));
    EXPECT_TRUE(
        rejected(edited(kValid, "profile = \"atv21\"\n", ""), {"bus 'line1' drive 'pump': missing key 'profile'"}));
}

TEST(Reject, DriveNameCharacters) {
    EXPECT_TRUE(rejected(edited(kValid, R"("pump")", R"("Pump/1")"), {"drive #1", "name 'Pump/1' is not made of"}));
}

TEST(Reject, DuplicateDriveNamesOnABus) {
    const auto text = std::string(kValid) + R"(
  [[bus.drive]]
  name = "pump"
  address = 2
  profile = "atv21"
)";
    EXPECT_TRUE(rejected(text, {"bus 'line1' drive 'pump': name 'pump' is already a drive of bus 'line1'"}));
}

TEST(Reject, DuplicateDriveNamesAcrossBuses) {
    const auto text = std::string(kValid) + edited(edited(kValid, "line1", "line2"), "ttyUSB0", "ttyUSB1");
    EXPECT_TRUE(rejected(text, {"bus 'line2' drive 'pump': name 'pump' is already a drive of bus 'line1'"}));
}

TEST(Reject, DuplicateAddressesOnABus) {
    const auto text = std::string(kValid) + R"(
  [[bus.drive]]
  name = "pump2"
  address = 1
  profile = "atv21"
)";
    EXPECT_TRUE(rejected(text, {"bus 'line1' drive 'pump2': address 1 is already drive 'pump'"}));
}

TEST(Read, SameAddressOnTwoBusesIsFine) {
    const auto text = std::string(kValid) +
                      edited(edited(edited(kValid, "line1", "line2"), "ttyUSB0", "ttyUSB1"), "\"pump\"", "\"pump2\"");
    EXPECT_EQ(parsed(text).buses.size(), 2U);
}

TEST(Reject, AddressOutsideTheProfileRange) {
    EXPECT_TRUE(rejected(edited(kFan, "address = 2", "address = 40"),
                         {"test.toml: bus 'line1' drive 'fan': address 40 is outside 1-31 for Altivar 58"}));
    EXPECT_TRUE(
        rejected(edited(kValid, "address = 1", "address = 248"), {"address 248 is outside 1-247 for Altivar 21"}));
}

TEST(Reject, BroadcastAddress) {
    EXPECT_TRUE(rejected(edited(kValid, "address = 1", "address = 0"),
                         {"bus 'line1' drive 'pump': address 0 is outside 1-247"}));
}

TEST(Reject, UnknownProfileSaysWhereItLooked) {
    EXPECT_TRUE(
        rejected(edited(kValid, R"("atv21")", R"("atv99")"),
                 {"bus 'line1' drive 'pump': profile: no profile 'atv99'", "atv99.toml", DRIVEBUS_TEST_PROFILE_DIR}));
}

TEST(Reject, UnknownProfileInTheGivenDirectory) {
    const ScratchDir dir;
    EXPECT_TRUE(rejected(kValid,
                         {"drive 'pump': profile: no profile 'atv21'", "atv21.toml is not in", dir.path().string()},
                         LoadOptions{dir.path()}));
}

TEST(Reject, ProfileThatDoesNotLoad) {
    const ScratchDir dir;
    dir.write("atv21.toml", "schema = 2\n");
    EXPECT_TRUE(rejected(kValid, {"drive 'pump': profile: ", "atv21.toml", "schema 2"}, LoadOptions{dir.path()}));
    dir.write("atv21.toml", kWriteOnlyProfile);  // drive.type "wo"
    EXPECT_TRUE(rejected(kValid, {"drive 'pump': profile: ", "drive.type is 'wo'"}, LoadOptions{dir.path()}));
}

TEST(Reject, ProfileTypeThatIsNotAName) {
    EXPECT_TRUE(rejected(edited(kValid, R"("atv21")", R"("../atv21")"),
                         {"drive 'pump': profile: ", "'../atv21' is not made of"}));
}

TEST(Reject, ParityTheProfileDoesNotList) {
    // The bus defaults to even parity; the Altivar 58 only speaks none.
    EXPECT_TRUE(rejected(edited(kFan, "parity = \"none\"\n", ""),
                         {"bus 'line1' drive 'fan': the bus's parity 'even' is not one Altivar 58 lists (none)"}));
}

TEST(Reject, BaudTheProfileDoesNotList) {
    EXPECT_TRUE(rejected(with_bus("baud = 38400"),
                         {"bus 'line1' drive 'pump': the bus's baud 38400 is not one Altivar 21 lists (9600, 19200)"}));
    EXPECT_TRUE(rejected(edited(kFan, "parity", "baud = 9600\nparity"), {"drive 'fan'", "baud 9600", "(19200)"}));
}

TEST(Reject, StopBitsTheProfileStates) {
    EXPECT_TRUE(rejected(edited(kFan, "parity", "stop_bits = 2\nparity"),
                         {"bus 'line1' drive 'fan': the bus's stop_bits 2 is not the 1 that Altivar 58 uses"}));
}

TEST(Reject, KeepAliveShorterThan10ms) {
    EXPECT_TRUE(
        rejected(with_drive(R"(keep_alive = "9ms")"), {"bus 'line1' drive 'pump': keep_alive 9ms is below 10ms"}));
    EXPECT_TRUE(rejected(with_drive(R"(keep_alive = "on")"), {"drive 'pump': keep_alive 'on'"}));
}

// ---------------------------------------------------------------------------------------------
// Validation: [[bus.drive.poll]]

TEST(Reject, PollMissingRegisters) {
    EXPECT_TRUE(rejected(edited(kValid, R"(registers = ["FD00", "FD01"])", ""),
                         {"bus 'line1' drive 'pump' poll 'fast': missing key 'registers'"}));
}

TEST(Reject, PollMissingPeriod) {
    EXPECT_TRUE(rejected(edited(kValid, "period = \"100ms\"\n", ""),
                         {"bus 'line1' drive 'pump' poll 'fast': missing key 'period'"}));
}

TEST(Reject, PollPeriodOutside1msTo1h) {
    EXPECT_TRUE(rejected(edited(kValid, R"("100ms")", R"("0ms")"), {"poll 'fast': period 0ms is below 1ms"}));
    EXPECT_TRUE(rejected(edited(kValid, R"("100ms")", R"("3601s")"), {"poll 'fast': period 3601s is above 3600s"}));
}

TEST(Reject, PollRegistersEmptyOrNotAnArray) {
    EXPECT_TRUE(rejected(polling("[]"), {"poll 'fast': registers is empty"}));
    EXPECT_TRUE(rejected(polling(R"("FD00")"), {"poll 'fast': registers must be an array"}));
    EXPECT_TRUE(rejected(polling("[true]"), {"poll 'fast': registers[0] must be a register name or number"}));
}

TEST(Reject, RegisterNameNotInTheProfile) {
    EXPECT_TRUE(
        rejected(polling(R"(["FD00", "FD99"])"),
                 {"bus 'line1' drive 'pump' poll 'fast': registers[1] 'FD99' is not a register of Altivar 21"}));
}

TEST(Reject, RegisterNumberOutOfRange) {
    EXPECT_TRUE(rejected(polling("[65536]"), {"poll 'fast': registers[0] 65536 is not a register number"}));
    EXPECT_TRUE(rejected(polling(R"(["0x10000"])"), {"poll 'fast': registers[0] 0x10000 is not a register number"}));
    EXPECT_TRUE(rejected(polling("[-1]"), {"poll 'fast': registers[0] -1 is not a register number"}));
}

TEST(Reject, RegisterWithoutAddress) {
    EXPECT_TRUE(rejected(polling(R"(["CMOD"])"), {"poll 'fast': registers[0] CMOD has no Modbus address"}));
}

TEST(Reject, WriteOnlyRegister) {
    const ScratchDir dir;
    dir.write("wo.toml", kWriteOnlyProfile);
    EXPECT_TRUE(rejected(wo_config(R"(["ST", "CMD"])"), {"drive 'pump' poll 'fast': registers[1] CMD is write-only"},
                         LoadOptions{dir.path()}));
    // By number too.
    EXPECT_TRUE(
        rejected(wo_config(R"(["0x0010"])"), {"poll 'fast': registers[0] CMD is write-only"}, LoadOptions{dir.path()}));
}

TEST(Reject, RegisterListedTwice) {
    EXPECT_TRUE(
        rejected(polling(R"(["FD00", "FD01", "0xFD00"])"), {"poll 'fast': registers[2] FD00 is already registers[0]"}));
}

TEST(Reject, PollNameCharactersAndDuplicates) {
    EXPECT_TRUE(rejected(edited(kValid, R"("fast")", R"("Fast!")"), {"poll #1", "name 'Fast!' is not made of"}));
    const auto text = with_poll(R"(
    [[bus.drive.poll]]
    name = "fast"
    registers = ["FC90"]
    period = "1s")");
    EXPECT_TRUE(rejected(text, {"drive 'pump' poll 'fast': name 'fast' is already another poll"}));
}

TEST(Reject, IndirectWithoutReadBlock) {
    EXPECT_TRUE(
        rejected(edited(kFan, "period", "indirect = true\n    period"),
                 {"bus 'line1' drive 'fan' poll #1: indirect = true, but Altivar 58 has no indirect read block"}));
}

TEST(Reject, IndirectMoreRegistersThanTheBlock) {
    const auto text = edited(with_poll("indirect = true"), R"(["FD00", "FD01"])",
                             R"(["FD00", "FD01", "FE03", "FE05", "FC91", "FE22"])");
    EXPECT_TRUE(rejected(text, {"poll 'fast': the indirect read block of Altivar 21 reads 2-5 registers, not 6"}));
}

TEST(Reject, IndirectFewerRegistersThanTheBlock) {
    const auto text = edited(with_poll("indirect = true"), R"(["FD00", "FD01"])", R"(["FD00"])");
    EXPECT_TRUE(rejected(text, {"poll 'fast': the indirect read block of Altivar 21 reads 2-5 registers, not 1"}));
}

TEST(Reject, IndirectRegisterNotAChoice) {
    const auto text = edited(with_poll("indirect = true"), R"(["FD00", "FD01"])", R"(["FD00", "FA01"])");
    EXPECT_TRUE(rejected(text, {"poll 'fast': registers[1] FA01 is not one the indirect read block of Altivar 21 "
                                "can select (FD01, FD00"}));
    const auto number = edited(with_poll("indirect = true"), R"(["FD00", "FD01"])", R"(["FD00", "0x1234"])");
    EXPECT_TRUE(rejected(number, {"poll 'fast': registers[1] 0x1234 is not one the indirect read block"}));
}

TEST(Read, IndirectWithinTheBlock) {
    const auto poll = parsed(with_poll("indirect = true")).buses.at(0).drives.at(0).polls.at(0);
    EXPECT_TRUE(poll.indirect);
    EXPECT_EQ(addresses(poll), (std::vector<std::uint16_t>{0xFD00, 0xFD01}));
}

TEST(Reject, TwoIndirectPollsThatDisagree) {
    // The block has one set of selectors: the second group would read what the first selected.
    const auto text = with_poll(
        "indirect = true\n    [[bus.drive.poll]]\n    name = \"slow\"\n"
        "    registers = [\"FE03\", \"FE05\"]\n    indirect = true\n    period = \"1s\"");
    EXPECT_TRUE(rejected(text, {"drive 'pump'", "poll 'slow' and poll 'fast' both read the indirect read block"}));
    const auto same = with_poll(
        "indirect = true\n    [[bus.drive.poll]]\n    name = \"slow\"\n"
        "    registers = [\"FD00\", \"FD01\"]\n    indirect = true\n    period = \"1s\"");
    EXPECT_EQ(parsed(same).buses.at(0).drives.at(0).polls.size(), 2U);
}

TEST(Read, WriteBlock) {
    const auto pump = parsed(with_drive(R"(write_block = ["fa00", "FA01"])")).buses.at(0).drives.at(0);
    EXPECT_EQ(pump.write_block, (std::vector<std::uint16_t>{0xFA00, 0xFA01}));
    EXPECT_TRUE(parsed(kValid).buses.at(0).drives.at(0).write_block.empty());
}

TEST(Reject, WriteBlock) {
    EXPECT_TRUE(rejected(with_drive(R"(write_block = ["FA00"])"),
                         {"drive 'pump'", "write_block names 1 registers", "Altivar 21 takes 2-2"}));
    EXPECT_TRUE(rejected(with_drive(R"(write_block = ["FA00", "FD00"])"),
                         {"drive 'pump'",
                          "write_block 'FD00' is not one the indirect write block of Altivar 21 can "
                          "select (FA00, FA20, FA01, FA50, FA51, FA13)"}));
    EXPECT_TRUE(rejected(with_drive(R"(write_block = ["FA00", "fa00"])"), {"write_block names FA00 twice"}));
    EXPECT_TRUE(rejected(with_drive("write_block = \"FA00\""), {"write_block"}));
    EXPECT_TRUE(
        rejected(edited(kFan, "profile = \"atv58\"\n", "profile = \"atv58\"\nwrite_block = [\"W400\", \"W401\"]\n"),
                 {"drive 'fan'", "write_block is set, but Altivar 58 has no indirect write block"}));
}

TEST(Drive, CommTimeoutIsWholeStepsOfTheProfilesTimeOutRegister) {
    EXPECT_FALSE(parsed(kValid).buses.at(0).drives.at(0).comm_timeout.has_value());
    EXPECT_EQ(parsed(with_drive(R"(comm_timeout = "2s")")).buses.at(0).drives.at(0).comm_timeout, Duration(2s));
    EXPECT_EQ(parsed(with_drive(R"(comm_timeout = "100s")")).buses.at(0).drives.at(0).comm_timeout, Duration(100s));
    EXPECT_TRUE(rejected(with_drive(R"(comm_timeout = "1500ms")"),
                         {"drive 'pump'",
                          "comm_timeout 1500ms is not a whole number of F803's steps of 1s "
                          "between 1s and 100s"}));
    EXPECT_TRUE(rejected(with_drive(R"(comm_timeout = "101s")"), {"comm_timeout 101s"}));
    EXPECT_TRUE(rejected(with_drive(R"(comm_timeout = "0s")"), {"comm_timeout"}));
    EXPECT_TRUE(rejected(with_drive("comm_timeout = 2"), {"comm_timeout"}));
    EXPECT_TRUE(
        rejected(edited(kFan, "profile = \"atv58\"\n", "profile = \"atv58\"\ncomm_timeout = \"2s\"\n"),
                 {"drive 'fan'", "comm_timeout is set, but profile 'atv58' names no Modbus time-out register"}));
}

TEST(Warnings, ALeaseThatCanOnlyHold) {
    // The ATV58 profile gives no stop or freewheel word: a dead application leaves it running.
    const auto fan = start_up_warnings(parsed(kFan));
    ASSERT_EQ(fan.size(), 1U);
    EXPECT_NE(fan[0].find("bus 'line1' drive 'fan': profile 'atv58' gives no stop or freewheel command word"),
              std::string::npos)
        << fan[0];
    EXPECT_NE(fan[0].find("\"hold\""), std::string::npos) << fan[0];
    // The ATV21 can stop, even when its configuration chose to hold.
    EXPECT_TRUE(start_up_warnings(parsed(kValid)).empty());
    EXPECT_TRUE(start_up_warnings(parsed(with_drive("fallback = \"hold\""))).empty());
}

// ---------------------------------------------------------------------------------------------
// Validation: what the shared-memory payloads (drivebus/shm.hpp) can carry. Each limit is taken
// from shm.hpp: at the limit accepted, one past it refused with a line naming key and limit.

// A name of `n` characters.
std::string name_of(std::size_t n) {
    return std::string(n, 'a');
}
std::string limit_text(std::size_t field_size) {
    return "more than the " + std::to_string(field_size - 1);
}

TEST(ShmLimits, BusName) {
    const auto most = shm::kNameSize - 1;
    EXPECT_EQ(parsed(edited(kValid, "\"line1\"", '"' + name_of(most) + '"')).buses.at(0).name.size(), most);
    EXPECT_TRUE(rejected(edited(kValid, "\"line1\"", '"' + name_of(most + 1) + '"'),
                         {"name '" + name_of(most + 1) + "' has " + std::to_string(most + 1) + " characters",
                          limit_text(shm::kNameSize), "a bus name in shared memory"}));
}

TEST(ShmLimits, DriveName) {
    const auto most = shm::kNameSize - 1;
    EXPECT_EQ(parsed(edited(kValid, "\"pump\"", '"' + name_of(most) + '"')).buses.at(0).drives.at(0).name.size(), most);
    EXPECT_TRUE(rejected(edited(kValid, "\"pump\"", '"' + name_of(most + 1) + '"'),
                         {"bus 'line1' drive", "name '" + name_of(most + 1) + "'", limit_text(shm::kNameSize),
                          "a drive name in shared memory"}));
}

TEST(ShmLimits, ProfileType) {
    const ScratchDir dir;
    const auto most = shm::kProfileSize - 1;
    for (const auto n : {most, most + 1}) {
        dir.write(name_of(n) + ".toml", edited(kWriteOnlyProfile, "\"wo\"", '"' + name_of(n) + '"'));
    }
    const auto typed = [&](std::size_t n) { return edited(wo_config(R"(["ST"])"), "\"wo\"", '"' + name_of(n) + '"'); };
    EXPECT_EQ(parsed(typed(most), LoadOptions{dir.path()}).buses.at(0).drives.at(0).profile->type.size(), most);
    EXPECT_TRUE(rejected(typed(most + 1),
                         {"drive 'pump': profile '" + name_of(most + 1) + "'", limit_text(shm::kProfileSize)},
                         LoadOptions{dir.path()}));
}

TEST(ShmLimits, Device) {
    const std::string prefix = "/dev/";
    const auto most = shm::kDeviceSize - 1;
    const auto device = [&](std::size_t n) { return prefix + name_of(n - prefix.size()); };
    EXPECT_EQ(parsed(edited(kValid, "/dev/ttyUSB0", device(most))).buses.at(0).device.string().size(), most);
    EXPECT_TRUE(rejected(edited(kValid, "/dev/ttyUSB0", device(most + 1)),
                         {"bus 'line1': device '" + device(most + 1) + "'", limit_text(shm::kDeviceSize)}));
}

// kValid with `n` drives on its bus, at addresses 1..n.
std::string with_drives(std::size_t n) {
    std::string text(kValid);
    for (std::size_t i = 2; i <= n; ++i) {
        text += "  [[bus.drive]]\n  name = \"d" + std::to_string(i) + "\"\n  address = " + std::to_string(i) +
                "\n  profile = \"atv21\"\n";
    }
    return text;
}

TEST(ShmLimits, DrivesPerBus) {
    EXPECT_EQ(parsed(with_drives(shm::kMaxDrivesPerBus)).buses.at(0).drives.size(), shm::kMaxDrivesPerBus);
    EXPECT_TRUE(rejected(with_drives(shm::kMaxDrivesPerBus + 1),
                         {"bus 'line1': " + std::to_string(shm::kMaxDrivesPerBus + 1) + " drives ([[bus.drive]])",
                          "more than the " + std::to_string(shm::kMaxDrivesPerBus)}));
}

// kValid whose drive has a second poll group "slow": together they read FD00, FD01 (the first
// group) and `extra` numbered registers (0x7000 up), `repeated` of them read by both groups.
std::string polling_in_two_groups(std::size_t extra, std::size_t repeated) {
    std::string first = R"(["FD00", "FD01")";
    for (std::size_t i = 0; i < repeated; ++i) {
        first += ", " + std::to_string(0x7000 + i);
    }
    std::string second = "[";
    for (std::size_t i = 0; i < extra; ++i) {
        second += (i == 0 ? "" : ", ") + std::to_string(0x7000 + i);
    }
    second += "]";
    return edited(kValid, R"(["FD00", "FD01"])", first + "]") +
           "\n    [[bus.drive.poll]]\n    name = \"slow\"\n    registers = " + second + "\n    period = \"1s\"\n";
}

TEST(ShmLimits, RegistersPerSnapshotOverAllPollGroups) {
    const auto most = shm::kMaxSnapshotRegisters;
    // A register in both groups is one entry of the snapshot.
    const auto fit = parsed(polling_in_two_groups(most - 2, 10)).buses.at(0).drives.at(0);
    ASSERT_EQ(fit.polls.size(), 2U);
    EXPECT_EQ(fit.polls[0].registers.size() + fit.polls[1].registers.size(), most + 10);
    EXPECT_TRUE(rejected(
        polling_in_two_groups(most - 1, 10),
        {"bus 'line1' drive 'pump' poll 'slow': registers", "read " + std::to_string(most + 1) + " different registers",
         "more than the " + std::to_string(most) + " a snapshot"}));
}

TEST(ShmLimits, GroupNames) {
    const auto most = shm::kGroupSize - 1;
    const std::string bus(kValid);
    for (const std::string key : {"watch_group", "control_group", "daemon_group"}) {
        EXPECT_EQ(parsed("[ipc]\n" + key + " = \"" + name_of(most) + "\"\n" + bus).ipc.max_clients, 32U) << key;
        EXPECT_TRUE(rejected("[ipc]\n" + key + " = \"" + name_of(most + 1) + "\"\n" + bus,
                             {key + " '" + name_of(most + 1) + "'", limit_text(shm::kGroupSize)}))
            << key;
    }
}

// The limits stated in the documentation are shm.hpp's, next to the keys they bound.
std::string source_file(std::string_view name) {
    std::ifstream in(fs::path(DRIVEBUS_TEST_SOURCE_DIR) / name);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

TEST(ShmLimits, TheDocumentationStatesShmHppsNumbers) {
    const auto chars = [](std::size_t field_size) { return std::to_string(field_size - 1) + " characters"; };
    const auto doc = source_file("docs/configuration.md");
    for (const auto& row :
         {"| bus name | " + chars(shm::kNameSize), "| drive name | " + chars(shm::kNameSize),
          "| profile type | " + chars(shm::kProfileSize), "| serial device path | " + chars(shm::kDeviceSize),
          "| group names | " + chars(shm::kGroupSize),
          "| drives on one bus | " + std::to_string(shm::kMaxDrivesPerBus) + " |",
          "| registers in a drive's snapshot | " + std::to_string(shm::kMaxSnapshotRegisters) + " "}) {
        EXPECT_NE(doc.find(row), std::string::npos) << "docs/configuration.md has no row " << row;
    }
    // Next to the keys: `name` of [[bus]] and [[bus.drive]], `device`, `profile`, `registers`.
    EXPECT_NE(doc.find("unique, at most " + chars(shm::kNameSize) + " | names the bus's services"), std::string::npos);
    EXPECT_NE(doc.find("unique across all buses, at most " + chars(shm::kNameSize)), std::string::npos);
    EXPECT_NE(doc.find("absolute path, unique, at most " + chars(shm::kDeviceSize)), std::string::npos);
    EXPECT_NE(doc.find("...), at most " + chars(shm::kProfileSize)), std::string::npos);
    EXPECT_NE(doc.find("at most " + std::to_string(shm::kMaxSnapshotRegisters) + " different registers over all"),
              std::string::npos);
    EXPECT_NE(doc.find("A bus has at most " + std::to_string(shm::kMaxDrivesPerBus) + " drives"), std::string::npos);
    const auto man = source_file("man/drivebusd.toml.5");
    EXPECT_NE(man.find("bus and drive names\nof at most " + chars(shm::kNameSize)), std::string::npos);
    EXPECT_NE(man.find("profile types of at most " + std::to_string(shm::kProfileSize - 1)), std::string::npos);
    EXPECT_NE(man.find("device paths of at most " + std::to_string(shm::kDeviceSize - 1)), std::string::npos);
    EXPECT_NE(man.find("at most " + std::to_string(shm::kMaxDrivesPerBus) + " drives on a bus"), std::string::npos);
    EXPECT_NE(man.find("at most " + std::to_string(shm::kMaxSnapshotRegisters) + " different registers"),
              std::string::npos);
}

// ---- [ipc] and the control lease ----

TEST(Ipc, Defaults) {
    const auto c = parsed(kValid);
    EXPECT_EQ(c.ipc.roudi, RouDiMode::Auto);
    EXPECT_EQ(c.ipc.watch_group, "drivebus");
    EXPECT_EQ(c.ipc.control_group, "drivebus-control");
    EXPECT_EQ(c.ipc.daemon_group, "drivebusd");
    EXPECT_EQ(c.ipc.max_clients, 32U);
}

TEST(Ipc, Keys) {
    const auto c = parsed(std::string("[ipc]\nroudi = \"external\"\nwatch_group = \"plant\"\n"
                                      "control_group = \"operators\"\ndaemon_group = \"busd\"\nmax_clients = 8\n") +
                          std::string(kValid));
    EXPECT_EQ(c.ipc.roudi, RouDiMode::External);
    EXPECT_EQ(c.ipc.watch_group, "plant");
    EXPECT_EQ(c.ipc.control_group, "operators");
    EXPECT_EQ(c.ipc.daemon_group, "busd");
    EXPECT_EQ(c.ipc.max_clients, 8U);
}

TEST(Ipc, BadKeys) {
    const std::string bus(kValid);
    EXPECT_TRUE(rejected("[ipc]\nroudi = \"inside\"\n" + bus, {"roudi", "inside"}));
    EXPECT_TRUE(rejected("[ipc]\nwatch_group = \"two words\"\n" + bus, {"watch_group", "two words"}));
    EXPECT_TRUE(rejected("[ipc]\ncontrol_group = \"drivebus\"\n" + bus, {"three different groups"}));
    EXPECT_TRUE(rejected("[ipc]\nmax_clients = 0\n" + bus, {"max_clients"}));
    EXPECT_TRUE(rejected("[ipc]\nsegments = 2\n" + bus, {"segments"}));
}

TEST(Lease, DefaultsFollowTheProfile) {
    const auto pump = parsed(kValid).buses.at(0).drives.at(0);
    EXPECT_EQ(pump.lease, std::chrono::seconds(1));
    EXPECT_EQ(pump.fallback, LeaseFallback::Stop);  // the ATV21 profile defines a stop command word
    const auto fan = parsed(kFan).buses.at(0).drives.at(0);
    EXPECT_EQ(fan.fallback, LeaseFallback::Hold);  // the ATV58 profile gives no command word values
}

TEST(Lease, Keys) {
    const auto pump = parsed(with_drive("lease = \"250ms\"\nfallback = \"freewheel\"")).buses.at(0).drives.at(0);
    EXPECT_EQ(pump.lease, std::chrono::milliseconds(250));
    EXPECT_EQ(pump.fallback, LeaseFallback::Freewheel);
    EXPECT_EQ(parsed(with_drive("fallback = \"hold\"")).buses.at(0).drives.at(0).fallback, LeaseFallback::Hold);
}

TEST(Lease, BadKeys) {
    EXPECT_TRUE(rejected(with_drive("lease = \"10ms\""), {"drive 'pump'", "lease"}));
    EXPECT_TRUE(rejected(with_drive("fallback = \"brake\""), {"drive 'pump'", "fallback", "brake"}));
    EXPECT_TRUE(rejected(edited(kFan, "profile = \"atv58\"\n", "profile = \"atv58\"\nfallback = \"stop\"\n"),
                         {"drive 'fan'", "fallback \"stop\"", "atv58", "hold"}));
}

}  // namespace
}  // namespace drivebus::config
