// SPDX-License-Identifier: Apache-2.0
// What drivebusctl makes of bus status and snapshots, and its tables: built by hand here,
// no daemon.
#include <gtest/gtest.h>

#include "read_json.hpp"
#include "table.hpp"
#include "view.hpp"

namespace drivebus::ctl {
namespace {

constexpr std::int64_t kNow = 100'000'000'000;  // 100 s of CLOCK_MONOTONIC

const Profile& profile(const std::string& type) {
    static const Profile atv21 = load_profile(std::string(PROFILE_DIR) + "/atv21.toml").value();
    static const Profile atv58 = load_profile(std::string(PROFILE_DIR) + "/atv58.toml").value();
    return type == "atv21" ? atv21 : atv58;
}

shm::DriveSnapshot pump_snapshot() {
    shm::DriveSnapshot s;
    s.size = sizeof s;
    s.sequence = 42;
    s.published_ns = kNow - 20'000'000;
    shm::assign(s.bus, "line1");
    shm::assign(s.name, "pump");
    shm::assign(s.profile, "atv21");
    s.address = 1;
    s.health = shm::DriveHealth::Online;
    const std::vector<std::pair<std::uint16_t, std::uint16_t>> values = {
        {0xFA01, 3000}, {0xFC90, 24}, {0xFC91, 0x0081}, {0xFD00, 2950}, {0xFD01, 0x4406}};
    for (const auto& [address, value] : values) {
        s.registers[s.register_count++] = {address, value, 1, {}, kNow - 35'000'000};
    }
    s.registers[s.register_count - 1].valid = 0;  // FD01's last read failed
    s.lease.state = shm::LeaseState::Held;
    shm::assign(s.lease.holder, "pump-control[77]");
    s.lease.holder_pid = 77;
    s.lease.expires_ns = kNow + 800'000'000;
    s.lease.fallback = shm::Fallback::Stop;
    return s;
}

shm::BusStatus bus_status() {
    shm::BusStatus b;
    b.size = sizeof b;
    b.published_ns = kNow - 300'000'000;
    b.daemon_pid = 1234;
    b.baud = 19200;
    shm::assign(b.bus, "line1");
    shm::assign(b.device, "/dev/ttyUSB0");
    shm::assign(b.format, "8E1");
    b.up = 1;
    b.drive_count = 2;
    b.drives_online = 1;
    b.counters.replies = 1000;
    b.counters.timeouts = 3;
    b.reply_latency = {1000, 12'340'000, 20'000'000};
    shm::assign(b.drives[0].name, "pump");
    shm::assign(b.drives[0].profile, "atv21");
    b.drives[0].address = 1;
    b.drives[0].health = shm::DriveHealth::Online;
    shm::assign(b.drives[1].name, "fan");
    shm::assign(b.drives[1].profile, "atv58");
    b.drives[1].address = 2;
    b.drives[1].health = shm::DriveHealth::Absent;
    return b;
}

TEST(CtlTable, ColumnsAlignAndTrailingSpaceGoes) {
    const auto text = render_table({{"NAME", "ADDRESS", "TITLE"}, {"FD00", "0xFD00", ""}, {"W450", "0x01C2", "x"}});
    EXPECT_EQ(text, "NAME  ADDRESS  TITLE\nFD00  0xFD00\nW450  0x01C2   x\n");
    EXPECT_EQ(render_table({{"a", "b"}}, "  "), "  a  b\n");
    EXPECT_EQ(render_table({}), "");
    // Width counts characters, not bytes.
    EXPECT_EQ(render_table({{"°C", "x"}, {"ab", "y"}}), "°C  x\nab  y\n");
    EXPECT_EQ(render_fields({{"bus", "line1"}, {"device", "/dev/x"}}), "bus     line1\ndevice  /dev/x\n");
}

TEST(CtlView, DriveStatusShowsStateLeaseAndEveryRegister) {
    auto s = pump_snapshot();
    s.registers[s.register_count - 1].valid = 1;
    const auto text = drive_status_text(s, &profile("atv21"), kNow);
    EXPECT_NE(text.find("pump (address 1, profile atv21, bus line1)"), std::string::npos) << text;
    EXPECT_NE(text.find("#42, 20 ms ago"), std::string::npos) << text;
    EXPECT_NE(
        text.find(
            "running forward, 29.50 Hz, fault Err5 (Communication error (Modbus time-out, see F803/F603)), alarms: "
            "Overcurrent alarm, Undercurrent alarm"),
        std::string::npos)
        << text;
    EXPECT_NE(text.find("held by pump-control[77] (expires in 800 ms); fallback stop, 0 expiries"), std::string::npos)
        << text;
    EXPECT_NE(text.find("FD00  0xFD00   2950   29.50 Hz  yes    35 ms  Output frequency"), std::string::npos) << text;
    EXPECT_NE(text.find("FA01  0xFA01   3000   30.00 Hz  yes"), std::string::npos) << text;
}

TEST(CtlView, InvalidRegistersSaySo) {
    const auto s = pump_snapshot();
    const auto text = drive_status_text(s, &profile("atv21"), kNow);
    EXPECT_NE(text.find("FD01  0xFD01   17414            no "), std::string::npos) << text;
    // Without the status word the state has no running/stopped.
    EXPECT_EQ(text.find("running"), std::string::npos) << text;
}

TEST(CtlView, DriveStatusJson) {
    auto s = pump_snapshot();
    s.registers[s.register_count - 1].valid = 1;
    const auto doc = test::json::parse(drive_status_json(s, &profile("atv21"), kNow).dump());
    EXPECT_EQ(doc["drive"].str(), "pump");
    EXPECT_EQ(doc["health"].str(), "online");
    EXPECT_EQ(doc["lease"]["state"].str(), "held");
    EXPECT_DOUBLE_EQ(doc["lease"]["expires_in_ms"].num(), 800);
    EXPECT_EQ(doc["state"]["fault_name"].str(), "Err5");
    EXPECT_DOUBLE_EQ(doc["state"]["output_hz"].num(), 29.5);
    const auto& fd00 = doc["registers"].find("name", "FD00");
    EXPECT_DOUBLE_EQ(fd00["raw"].num(), 2950);
    EXPECT_DOUBLE_EQ(fd00["value"].num(), 29.5);
    EXPECT_EQ(fd00["unit"].str(), "Hz");
    EXPECT_DOUBLE_EQ(fd00["age_ms"].num(), 35);
    EXPECT_EQ(doc["registers"].find("name", "FD01")["bits"][0].str(), "1 Fault");
}

TEST(CtlView, BusStatusTextAndJson) {
    const auto b = bus_status();
    const auto text = bus_status_text(b, true, kNow);
    EXPECT_NE(text.find("device         /dev/ttyUSB0, 19200 8E1"), std::string::npos) << text;
    EXPECT_NE(text.find("drives         1 of 2 online"), std::string::npos) << text;
    EXPECT_NE(text.find("reply latency  mean 12.34 ms, max 20.00 ms (1000 replies)"), std::string::npos) << text;
    EXPECT_NE(text.find("  timeouts          3"), std::string::npos) << text;
    EXPECT_NE(text.find("fan   2        atv58    absent"), std::string::npos) << text;
    const auto doc = test::json::parse(bus_status_json(b, false, kNow).dump());
    EXPECT_EQ(doc["bus"].str(), "line1");
    EXPECT_EQ(doc["format"].str(), "8E1");
    EXPECT_EQ(doc["can_request"].type, test::json::Value::Type::Bool);
    EXPECT_DOUBLE_EQ(doc["reply_latency"]["mean_ms"].num(), 12.34);
    EXPECT_DOUBLE_EQ(doc["counters"]["timeouts"].num(), 3);
    EXPECT_EQ(doc["drives"].find("name", "fan")["health"].str(), "absent");
}

// The drive's own Modbus time-out: in the list of drives, and in a drive's status.
TEST(CtlView, TheDrivesModbusTimeOutIsShown) {
    auto b = bus_status();
    b.drives[0].comm_timeout_state = shm::CommTimeoutState::Read;
    b.drives[0].comm_timeout_verdict = shm::CommTimeoutVerdict::Off;
    const auto rows = drive_rows(b);
    ASSERT_EQ(rows.size(), 3U);
    EXPECT_EQ(rows[0].back(), "TIME-OUT");
    EXPECT_EQ(rows[1].back(), "off");
    EXPECT_EQ(rows[2].back(), "-");  // not read
    b.drives[0].comm_timeout_ms = 1000;
    b.drives[0].comm_timeout_verdict = shm::CommTimeoutVerdict::MayFire;
    EXPECT_EQ(drive_rows(b)[1].back(), "1 s, may fire");
    const auto list = test::json::parse(drives_json(b).dump());
    EXPECT_EQ(list.find("name", "pump")["comm_timeout"]["verdict"].str(), "may fire");
    EXPECT_DOUBLE_EQ(list.find("name", "pump")["comm_timeout"]["timeout_ms"].num(), 1000);

    auto s = pump_snapshot();
    s.comm_timeout.state = shm::CommTimeoutState::Read;
    s.comm_timeout.verdict = shm::CommTimeoutVerdict::Off;
    s.comm_timeout.action_valid = 1;
    s.comm_timeout.action = 1;
    s.comm_timeout.gap_ms = 1150;
    auto text = drive_status_text(s, &profile("atv21"), kNow);
    EXPECT_NE(text.find("time-out  F803 = off; when it fires: F603 = 1 (Deceleration stop (Err5)); OFF: if the line "
                        "or drivebusd dies, the drive runs on"),
              std::string::npos)
        << text;
    s.comm_timeout.state = shm::CommTimeoutState::WriteRefused;
    s.comm_timeout.verdict = shm::CommTimeoutVerdict::Fine;
    s.comm_timeout.raw = 3;
    s.comm_timeout.timeout_ms = 3000;
    s.comm_timeout.wanted_ms = 2000;
    s.comm_timeout.exception = 4;
    text = drive_status_text(s, &profile("atv21"), kNow);
    EXPECT_NE(text.find("F803 = 3 s; writing the configured 2 s was refused (exception 4)"), std::string::npos) << text;
    EXPECT_NE(text.find("fine (drivebusd's requests at most 1.15 s apart)"), std::string::npos) << text;
    const auto doc = test::json::parse(drive_status_json(s, &profile("atv21"), kNow).dump());
    EXPECT_EQ(doc["comm_timeout"]["register"].str(), "F803");
    EXPECT_EQ(doc["comm_timeout"]["state"].str(), "write refused");
    EXPECT_DOUBLE_EQ(doc["comm_timeout"]["timeout_ms"].num(), 3000);
    EXPECT_DOUBLE_EQ(doc["comm_timeout"]["wanted_ms"].num(), 2000);
    EXPECT_DOUBLE_EQ(doc["comm_timeout"]["fault_action"].num(), 1);
    // A profile that names none.
    s.comm_timeout = {};
    EXPECT_NE(drive_status_text(s, &profile("atv58"), kNow).find("time-out  none named by the profile"),
              std::string::npos);
}

TEST(CtlView, WatchShowsStateForControlProfilesAndRegistersOtherwise) {
    auto pump = pump_snapshot();
    pump.registers[pump.register_count - 1].valid = 1;
    shm::DriveSnapshot fan;
    shm::assign(fan.name, "fan");
    fan.health = shm::DriveHealth::Online;
    fan.published_ns = kNow - 1'500'000'000;
    fan.registers[fan.register_count++] = {0x01C2, 12, 1, {}, kNow};
    fan.registers[fan.register_count++] = {0x01C3, 0, 0, {}, 0};
    const std::vector<WatchDrive> drives = {
        {"pump", 1, "atv21", shm::DriveHealth::Online, pump, &profile("atv21")},
        {"fan", 2, "atv58", shm::DriveHealth::Absent, fan, &profile("atv58")},
        {"spare", 3, "atv58", shm::DriveHealth::Unknown, std::nullopt, &profile("atv58")},
    };
    const auto lines = watch_lines(bus_status(), drives, std::chrono::milliseconds(200), kNow);
    std::string text;
    for (const auto& l : lines) {
        text += l + "\n";
        EXPECT_EQ(l.find('\x1b'), std::string::npos);
    }
    EXPECT_NE(text.find("every 200 ms; q quits"), std::string::npos) << text;
    EXPECT_NE(text.find("pump   1        atv21    online   20 ms  running forward, 29.50 Hz"), std::string::npos)
        << text;
    EXPECT_NE(text.find("fan    2        atv58    online   1.5 s  W450=12 W451=?"), std::string::npos) << text;
    EXPECT_NE(text.find("spare  3        atv58    unknown  -      no snapshot yet"), std::string::npos) << text;
    EXPECT_NE(text.find("bus line1: up, 1 of 2 drives online, 1000 replies, 3 timeouts, reply latency mean 12.34 ms"),
              std::string::npos)
        << text;

    const auto doc = test::json::parse(watch_json(bus_status(), drives, kNow).dump());
    EXPECT_DOUBLE_EQ(doc["bus"]["replies"].num(), 1000);
    EXPECT_EQ(doc["drives"].find("name", "pump")["state"]["running"].boolean, true);
    EXPECT_DOUBLE_EQ(doc["drives"].find("name", "pump")["values"]["FD00"].num(), 29.5);
    EXPECT_TRUE(doc["drives"].find("name", "fan")["values"]["W451"].is_null());
    EXPECT_TRUE(doc["drives"].find("name", "spare")["age_ms"].is_null());
}

TEST(CtlView, StateTextOfAStoppedDriveWithoutFault) {
    DriveState st;
    st.status_word = 0x4000;
    st.ready = true;
    st.output_hz = 0.0;
    st.fault_code = 0;
    EXPECT_EQ(state_text(st, profile("atv21")), "stopped, 0.00 Hz, no fault, no alarm");
    EXPECT_EQ(state_text(DriveState{}, profile("atv21")), "not polled");
    EXPECT_TRUE(has_state(&profile("atv21")));
    EXPECT_FALSE(has_state(&profile("atv58")));  // a [control] section without status or frequency
    EXPECT_FALSE(has_state(nullptr));
}

TEST(CtlView, RegisterJsonWithoutProfile) {
    const auto doc = test::json::parse(register_json(0x1234, 7, nullptr).dump());
    EXPECT_TRUE(doc["name"].is_null());
    EXPECT_EQ(doc["hex"].str(), "0x1234");
    EXPECT_DOUBLE_EQ(doc["raw"].num(), 7);
    EXPECT_FALSE(doc.has("value"));
}

}  // namespace
}  // namespace drivebus::ctl
