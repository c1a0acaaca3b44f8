// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt's pure parts, without a broker or drivebusd: configuration, topics, payloads,
// the deadband, commands and their plans, back-off.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "mqtt/backoff.hpp"
#include "mqtt/command.hpp"
#include "mqtt/config.hpp"
#include "mqtt/payload.hpp"
#include "mqtt/topics.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

Profile atv21() {
    auto p = load_profile(std::string(DRIVEBUS_TEST_PROFILE_DIR) + "/atv21.toml");
    EXPECT_TRUE(p) << p.error().message;
    return *p;
}

std::string error_of(std::string_view text) {
    auto c = parse_config(text, "mqtt.toml", "board");
    return c ? std::string("(valid)") : c.error().message;
}

TEST(MqttConfig, DefaultsAndOverrides) {
    auto c = parse_config(R"(
[[bus]]
name = "line1"
period = "5s"
deadband = 0.5
  [[bus.drive]]
  name = "pump"
  commands = true
  deadband = 0.1
)",
                          "mqtt.toml", "board-7");
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->node, "board-7");
    EXPECT_EQ(c->broker.host, "localhost");
    EXPECT_EQ(c->broker.port, 1883);
    EXPECT_EQ(c->client_id(), "drivebus-mqtt-board-7");
    ASSERT_EQ(c->buses.size(), 1U);
    const auto pump = c->buses[0].drive("pump");
    EXPECT_TRUE(pump.commands);
    EXPECT_DOUBLE_EQ(pump.deadband, 0.1);
    EXPECT_EQ(pump.period, 5s);
    const auto fan = c->buses[0].drive("fan");
    EXPECT_FALSE(fan.commands);
    EXPECT_DOUBLE_EQ(fan.deadband, 0.5);
    EXPECT_EQ(fan.period, 5s);
}

TEST(MqttConfig, ABadKeyIsOneLineNamingIt) {
    EXPECT_EQ(error_of("[broker]\nhots = \"x\"\n[[bus]]\nname = \"a\"\n"), "mqtt.toml: broker: unknown key 'hots'");
    EXPECT_EQ(error_of("[broker]\nport = 0\n[[bus]]\nname = \"a\"\n").find("mqtt.toml: broker: port"), 0U);
    EXPECT_NE(error_of("").find("no [[bus]]"), std::string::npos);
    EXPECT_EQ(error_of("node = \"a/b\"\n[[bus]]\nname = \"a\"\n"),
              "mqtt.toml: node 'a/b' is not a topic level (letters, digits, '_', '-', '.', at most 64)");
    EXPECT_EQ(error_of("[[bus]]\nname = \"a+\"\n"),
              "mqtt.toml: bus #1: name 'a+' is not a topic level (letters, digits, '_', '-', '.', at most 64)");
    EXPECT_EQ(parse_config("[[bus]]\nname = \"a\"\n", "mqtt.toml", "a/b").error().message,
              "mqtt.toml: node: the host name 'a/b' is not a topic level (letters, digits, '_', '-', '.', at most "
              "64): set node");
    EXPECT_NE(
        error_of("[[bus]]\nname = \"a\"\n[[bus.drive]]\nname = \"p\"\ncommands = 1\n").find("drive 'p': commands"),
        std::string::npos);
    EXPECT_NE(error_of("[[bus]]\nname = \"a\"\nperiod = \"10\"\n").find("period"), std::string::npos);
    EXPECT_NE(error_of("[broker.tls]\ncertfile = \"c\"\n[[bus]]\nname = \"a\"\n").find("cafile"), std::string::npos);
    EXPECT_NE(error_of("[broker]\npassword_file = \"/x\"\n[[bus]]\nname = \"a\"\n").find("needs username"),
              std::string::npos);
    EXPECT_NE(error_of("[[bus]]\nname = \"a\"\n[[bus]]\nname = \"a\"\n").find("listed twice"), std::string::npos);
    EXPECT_EQ(error_of("[[bus]]\nname = \"a\"\n").find('\n'), std::string::npos);
}

TEST(MqttConfig, PasswordComesFromItsFile) {
    const auto file = std::filesystem::temp_directory_path() / ("mqtt-pw-" + std::to_string(::getpid()));
    std::ofstream(file) << "s3cret\n";
    auto c = parse_config(
        "[broker]\nusername = \"board\"\npassword_file = \"" + file.string() + "\"\n[[bus]]\nname = \"a\"\n",
        "mqtt.toml", "b");
    std::filesystem::remove(file);
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->password, "s3cret");
    auto missing = parse_config(
        "[broker]\nusername = \"u\"\npassword_file = \"/nonexistent/pw\"\n[[bus]]\nname = \"a\"\n", "mqtt.toml", "b");
    ASSERT_FALSE(missing);
    EXPECT_NE(missing.error().message.find("password_file: /nonexistent/pw"), std::string::npos);
}

TEST(MqttTopics, LayoutAndParsing) {
    Topics t("board");
    EXPECT_EQ(t.node_status(), "drivebus/board/status");
    EXPECT_EQ(t.bus_status("line1"), "drivebus/board/line1/status");
    EXPECT_EQ(t.state("line1", "pump"), "drivebus/board/line1/pump/state");
    EXPECT_EQ(t.result("line1", "pump"), "drivebus/board/line1/pump/result");
    EXPECT_EQ(t.set_filter(), "drivebus/board/+/+/set");
    const auto target = t.parse_set("drivebus/board/line1/pump/set");
    ASSERT_TRUE(target);
    EXPECT_EQ(target->bus, "line1");
    EXPECT_EQ(target->drive, "pump");
    EXPECT_FALSE(t.parse_set("drivebus/board/line1/pump/state"));
    EXPECT_FALSE(t.parse_set("drivebus/boardx/line1/pump/set"));
    EXPECT_FALSE(t.parse_set("drivebus/board/line1/set"));
    EXPECT_FALSE(t.parse_set("drivebus/board/line1/a/b/set"));
    EXPECT_FALSE(t.parse_set("drivebus/board/line1/p$ump/set"));
}

void put(shm::DriveSnapshot& s, std::uint16_t address, std::uint16_t value, std::uint8_t valid = 1) {
    s.registers.at(s.register_count++) = {address, value, valid, {}, 1};
}

shm::DriveSnapshot pump_snapshot(std::uint16_t fd00) {
    shm::DriveSnapshot s{};
    shm::assign(s.bus, "line1");
    shm::assign(s.name, "pump");
    shm::assign(s.profile, "atv21");
    s.address = 1;
    s.health = shm::DriveHealth::Online;
    s.sequence = 7;
    put(s, 0xFA01, 4000);
    put(s, 0xFD00, fd00);
    put(s, 0xFD01, 0x6404);
    put(s, 0xFE03, 0, 0);
    return s;
}

TEST(MqttPayload, DriveStateHasNamesUnitsAndTheAltivarDecoding) {
    const auto profile = atv21();
    const auto j = drive_state(pump_snapshot(6000), &profile);
    EXPECT_EQ(j["drive"], "pump");
    EXPECT_EQ(j["bus"], "line1");
    EXPECT_EQ(j["health"], "online");
    EXPECT_EQ(j["registers"]["FD00"]["raw"], 6000);
    EXPECT_DOUBLE_EQ(j["registers"]["FD00"]["value"].get<double>(), 60.0);
    EXPECT_EQ(j["registers"]["FD00"]["unit"], "Hz");
    EXPECT_TRUE(j["registers"]["FE03"]["value"].is_null());
    EXPECT_EQ(j["altivar"]["running"], true);
    EXPECT_DOUBLE_EQ(j["altivar"]["output_hz"].get<double>(), 60.0);
    EXPECT_EQ(j["lease"]["state"], "free");
    EXPECT_EQ(j["comm_timeout"]["state"], "unknown");
    EXPECT_EQ(j["polled_ns"], 1);  // the newest valid sample's time
    // Without a profile: registers by number, raw values.
    const auto bare = drive_state(pump_snapshot(6000), nullptr);
    EXPECT_EQ(bare["registers"]["0xFD00"]["value"], 6000.0);
    EXPECT_FALSE(bare.contains("altivar"));
}

TEST(MqttPayload, DriveStateCarriesTheDrivesModbusTimeOut) {
    const auto profile = atv21();
    auto s = pump_snapshot(6000);
    s.comm_timeout.state = shm::CommTimeoutState::Read;
    s.comm_timeout.verdict = shm::CommTimeoutVerdict::Off;
    const auto off = drive_state(s, &profile);
    EXPECT_EQ(off["comm_timeout"]["state"], "read");
    EXPECT_EQ(off["comm_timeout"]["verdict"], "off");
    EXPECT_EQ(off["comm_timeout"]["timeout_ms"], 0);
    s.comm_timeout.verdict = shm::CommTimeoutVerdict::Fine;
    s.comm_timeout.timeout_ms = 3000;
    EXPECT_EQ(drive_state(s, &profile)["comm_timeout"]["timeout_ms"], 3000);
}

TEST(MqttPayload, DeadbandOnValuesOnly) {
    const auto profile = atv21();
    const auto a = drive_state(pump_snapshot(6000), &profile);
    auto later = pump_snapshot(6020);  // +0.2 Hz
    later.sequence = 99;
    later.counters.replies = 1234;
    const auto b = drive_state(later, &profile);
    EXPECT_FALSE(significant_change(a, b, 0.5));
    EXPECT_TRUE(significant_change(a, b, 0.1));
    // Counters and sequence alone never count.
    auto same = pump_snapshot(6000);
    same.sequence = 100;
    same.counters.timeouts = 5;
    EXPECT_FALSE(significant_change(a, drive_state(same, &profile), 0.0));
    // Health, lease or a status bit always count.
    auto absent = pump_snapshot(6000);
    absent.health = shm::DriveHealth::Absent;
    EXPECT_TRUE(significant_change(a, drive_state(absent, &profile), 1000.0));
    auto held = pump_snapshot(6000);
    held.lease.state = shm::LeaseState::Held;
    EXPECT_TRUE(significant_change(a, drive_state(held, &profile), 1000.0));
    auto stopped = pump_snapshot(6000);
    stopped.registers[2].value = 0x0000;
    EXPECT_TRUE(significant_change(a, drive_state(stopped, &profile), 1e9));
    // A value going invalid counts.
    auto invalid = pump_snapshot(6000);
    invalid.registers[1].valid = 0;
    EXPECT_TRUE(significant_change(a, drive_state(invalid, &profile), 1e9));
}

TEST(MqttPayload, BusStatus) {
    shm::BusStatus s{};
    shm::assign(s.bus, "line1");
    s.up = 1;
    s.drive_count = 1;
    s.drives_online = 1;
    shm::assign(s.drives[0].name, "pump");
    s.drives[0].health = shm::DriveHealth::Online;
    s.counters.replies = 10;
    const auto j = bus_status(s, true);
    EXPECT_EQ(j["up"], true);
    EXPECT_EQ(j["drivebusd"], "running");
    EXPECT_EQ(j["drives"]["pump"]["health"], "online");
    EXPECT_EQ(j["counters"]["replies"], 10);
    s.counters.replies = 11;
    EXPECT_FALSE(significant_change(j, bus_status(s, true), 0.0));
    EXPECT_TRUE(significant_change(j, bus_status(s, false), 0.0));
}

TEST(MqttCommand, ParsesRegistersVerbsAndIds) {
    auto c =
        parse_command(R"({"id": "c-1", "registers": {"FA01": 40.0, "FA00": {"raw": 50176}}, "verb": "run"})", 4096);
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->id, "c-1");
    ASSERT_EQ(c->registers.size(), 2U);
    EXPECT_EQ(c->verb, Verb::Run);
    auto n = parse_command(R"({"id": 17, "frequency": 35.5})", 4096);
    ASSERT_TRUE(n);
    EXPECT_EQ(n->id, 17);
    EXPECT_DOUBLE_EQ(*n->frequency, 35.5);
}

TEST(MqttCommand, RefusalsKeepTheIdWhenThereIsOne) {
    const auto refused = [](std::string_view text, std::size_t max = 4096) {
        auto c = parse_command(text, max);
        EXPECT_FALSE(c) << text;
        return c ? CommandError{} : c.error();
    };
    EXPECT_EQ(refused("{not json").message, "not JSON");
    EXPECT_EQ(refused("[1,2]").message, "not a JSON object");
    EXPECT_TRUE(refused(R"({"verb": "run"})").id.is_null());
    EXPECT_NE(refused(R"({"id": "x", "verb": "dance"})").message.find("unknown verb 'dance'"), std::string::npos);
    EXPECT_EQ(refused(R"({"id": "x", "verb": "dance"})").id, "x");
    EXPECT_NE(refused(R"({"id": "x"})").message.find("nothing to do"), std::string::npos);
    EXPECT_NE(refused(R"({"id": "x", "speed": 3})").message.find("unknown key 'speed'"), std::string::npos);
    EXPECT_NE(refused(R"({"id": "x", "registers": {"FA01": "fast"}})").message.find("FA01"), std::string::npos);
    EXPECT_NE(refused(R"({"id": "x", "verb": "heartbeat", "frequency": 3})").message.find("alone"), std::string::npos);
    EXPECT_NE(refused(std::string(5000, ' '), 4096).message.find("5000 bytes"), std::string::npos);
    EXPECT_NE(refused(R"({"id": ")" + std::string(200, 'a') + R"(", "verb": "run"})").message.find("id"),
              std::string::npos);
}

TEST(MqttCommand, PlansAgainstTheProfile) {
    const auto profile = atv21();
    auto c = parse_command(R"({"id": 1, "frequency": 40, "verb": "run"})", 4096);
    ASSERT_TRUE(c);
    auto p = plan(*c, &profile);
    ASSERT_TRUE(p) << p.error();
    ASSERT_EQ(p->size(), 2U);
    EXPECT_EQ((*p)[0].address, 0xFA01);
    EXPECT_EQ((*p)[0].raw, 4000);
    EXPECT_EQ((*p)[1].address, 0xFA00);
    EXPECT_EQ((*p)[1].raw, *profile.control->run_forward);
    auto hb = plan(*parse_command(R"({"id": 2, "verb": "heartbeat"})", 4096), &profile);
    ASSERT_TRUE(hb);
    ASSERT_EQ(hb->size(), 1U);
    EXPECT_EQ((*hb)[0].kind, Action::Kind::KeepAlive);
    const auto error = [&](std::string_view text) {
        auto planned = plan(*parse_command(text, 4096), &profile);
        EXPECT_FALSE(planned) << text;
        return planned ? std::string() : planned.error();
    };
    EXPECT_NE(error(R"({"id": 3, "registers": {"ZZ99": 1}})").find("unknown register 'ZZ99'"), std::string::npos);
    EXPECT_NE(error(R"({"id": 3, "registers": {"FD00": 1}})").find("read-only"), std::string::npos);
    EXPECT_NE(error(R"({"id": 3, "frequency": 5000})").find("outside"), std::string::npos);
    EXPECT_NE(error(R"({"id": 3, "registers": {"FA01": {"raw": 70000}}})").find("16-bit"), std::string::npos);
    // A reference without a unit (the ATV58's W401) takes no frequency; a raw word still goes.
    auto atv58 = load_profile(std::string(DRIVEBUS_TEST_PROFILE_DIR) + "/atv58.toml");
    ASSERT_TRUE(atv58) << atv58.error().message;
    const auto on58 = plan(*parse_command(R"({"id": 6, "frequency": 50})", 4096), &*atv58);
    ASSERT_FALSE(on58);
    EXPECT_NE(on58.error().find("frequency: the atv58 profile gives its frequency reference W401 no unit"),
              std::string::npos)
        << on58.error();
    const auto raw58 = plan(*parse_command(R"({"id": 7, "registers": {"W401": {"raw": 500}}})", 4096), &*atv58);
    ASSERT_TRUE(raw58) << raw58.error();
    EXPECT_EQ((*raw58)[0].raw, 500);
    // No profile: numbers and raw words only; no verbs.
    EXPECT_FALSE(plan(*parse_command(R"({"id": 4, "verb": "run"})", 4096), nullptr));
    auto raw = plan(*parse_command(R"({"id": 5, "registers": {"0x0010": 7}})", 4096), nullptr);
    ASSERT_TRUE(raw);
    EXPECT_EQ((*raw)[0].address, 0x10);
}

TEST(MqttCommand, Results) {
    EXPECT_EQ(result_ok("a").dump(), R"({"id":"a","ok":true})");
    const auto e = result_error(7, "commands_disabled", "no");
    EXPECT_EQ(e["id"], 7);
    EXPECT_EQ(e["ok"], false);
    EXPECT_EQ(e["reason"], "commands_disabled");
}

TEST(MqttBackoff, DoublesToTheCapAndResets) {
    Backoff b(1s, 8s);
    EXPECT_EQ(b.next(), 1s);
    EXPECT_EQ(b.next(), 2s);
    EXPECT_EQ(b.next(), 4s);
    EXPECT_EQ(b.next(), 8s);
    EXPECT_EQ(b.next(), 8s);
    EXPECT_EQ(b.failures(), 5U);
    // The random part takes at most half off.
    EXPECT_GE(b.next(0.99), 4s);
    b.reset();
    EXPECT_EQ(b.failures(), 0U);
    EXPECT_EQ(b.next(0.5), 750ms);
}

}  // namespace
}  // namespace drivebus::mqtt
