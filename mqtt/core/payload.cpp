// SPDX-License-Identifier: Apache-2.0
#include "mqtt/payload.hpp"

#include <cmath>
#include <cstdio>
#include <string>

#include "drivebus/altivar.hpp"

namespace drivebus::mqtt {
namespace {

std::string hex(std::uint16_t address) {
    std::array<char, 8> text{};
    std::snprintf(text.data(), text.size(), "0x%04X", address);
    return text.data();
}

Json register_json(const shm::RegisterSample& sample, const RegisterInfo* info) {
    Json r = Json::object();
    r["address"] = sample.address;
    if (sample.valid == 0) {
        r["value"] = nullptr;
        r["raw"] = nullptr;
    } else {
        r["raw"] = sample.value;
        r["value"] = info != nullptr ? info->to_engineering(sample.value) : static_cast<double>(sample.value);
    }
    if (info != nullptr && !info->unit.empty()) {
        r["unit"] = info->unit;
    }
    return r;
}

Json altivar_json(const Profile& profile, const shm::DriveSnapshot& snapshot) {
    const auto st = decode_state(profile, snapshot);
    Json a = Json::object();
    a["running"] = st.running;
    a["reverse"] = st.reverse;
    a["fault"] = st.fault;
    a["alarm"] = st.alarm;
    a["ready"] = st.ready;
    a["status_word"] = st.status_word ? Json(*st.status_word) : Json(nullptr);
    a["output_hz"] = st.output_hz ? Json(*st.output_hz) : Json(nullptr);
    a["fault_code"] = st.fault_code ? Json(*st.fault_code) : Json(nullptr);
    a["fault_name"] = st.fault_name;
    a["fault_title"] = st.fault_title;
    a["alarms"] = st.alarms;
    a["flags"] = st.flags;
    return a;
}

Json lease_json(const shm::LeaseStatus& lease) {
    Json l = Json::object();
    l["state"] = shm::to_string(lease.state);
    l["holder"] = std::string(shm::view(lease.holder));
    l["holder_pid"] = lease.holder_pid;
    l["duration_ms"] = lease.duration_ms;
    l["fallback"] = shm::to_string(lease.fallback);
    l["fallback_ok"] = lease.fallback_ok != 0;
    l["expiries"] = lease.expiries;
    return l;
}

// Fields that change with every sample and say nothing about the drive.
bool ignored(std::string_view key) {
    return key == "sequence" || key == "counters" || key == "raw" || key == "polled_ns";
}

bool differs(const Json& a, const Json& b, double deadband, bool is_value) {
    if (is_value && a.is_number() && b.is_number()) {
        return std::fabs(a.get<double>() - b.get<double>()) > deadband;
    }
    if (a.is_object() && b.is_object()) {
        if (a.size() != b.size()) {
            return true;
        }
        for (const auto& [key, value] : a.items()) {
            if (ignored(key)) {
                continue;
            }
            const auto other = b.find(key);
            if (other == b.end() || differs(value, *other, deadband, key == "value" || key == "output_hz")) {
                return true;
            }
        }
        return false;
    }
    return a != b;
}

}  // namespace

Json drive_state(const shm::DriveSnapshot& snapshot, const Profile* profile) {
    Json j = Json::object();
    j["bus"] = std::string(shm::view(snapshot.bus));
    j["drive"] = std::string(shm::view(snapshot.name));
    j["address"] = snapshot.address;
    j["profile"] = std::string(shm::view(snapshot.profile));
    j["health"] = shm::to_string(snapshot.health);
    j["sequence"] = snapshot.sequence;
    Json regs = Json::object();
    std::int64_t polled_ns = 0;
    const std::size_t count = std::min<std::size_t>(snapshot.register_count, snapshot.registers.size());
    for (std::size_t i = 0; i < count; ++i) {
        const auto& sample = snapshot.registers[i];
        if (sample.valid != 0) {
            polled_ns = std::max(polled_ns, sample.time_ns);
        }
        const RegisterInfo* info = profile != nullptr ? profile->find(sample.address) : nullptr;
        regs[info != nullptr ? info->name : hex(sample.address)] = register_json(sample, info);
    }
    j["registers"] = std::move(regs);
    j["polled_ns"] = polled_ns;
    if (profile != nullptr && profile->control) {
        j["altivar"] = altivar_json(*profile, snapshot);
    }
    j["lease"] = lease_json(snapshot.lease);
    const auto& timeout = snapshot.comm_timeout;  // the drive's own Modbus time-out (ATV21 F803)
    j["comm_timeout"] = {{"state", shm::to_string(timeout.state)},
                         {"verdict", shm::to_string(timeout.verdict)},
                         {"timeout_ms", timeout.timeout_ms}};
    Json c = Json::object();
    c["requests"] = snapshot.counters.requests;
    c["replies"] = snapshot.counters.replies;
    c["timeouts"] = snapshot.counters.timeouts;
    c["bad_frames"] = snapshot.counters.bad_frames;
    c["exceptions"] = snapshot.counters.exceptions;
    j["counters"] = std::move(c);
    return j;
}

Json bus_status(const shm::BusStatus& status, bool daemon_alive) {
    Json j = Json::object();
    j["bus"] = std::string(shm::view(status.bus));
    j["drivebusd"] = daemon_alive ? "running" : "silent";
    j["up"] = status.up != 0;
    j["device"] = std::string(shm::view(status.device));
    j["baud"] = status.baud;
    j["format"] = std::string(shm::view(status.format));
    j["drive_count"] = status.drive_count;
    j["drives_online"] = status.drives_online;
    Json drives = Json::object();
    const std::size_t count = std::min<std::size_t>(status.drive_count, status.drives.size());
    for (std::size_t i = 0; i < count; ++i) {
        const auto& d = status.drives[i];
        drives[std::string(shm::view(d.name))] = {{"address", d.address},
                                                  {"profile", std::string(shm::view(d.profile))},
                                                  {"health", shm::to_string(d.health)}};
    }
    j["drives"] = std::move(drives);
    Json c = Json::object();
#define DRIVEBUS_MQTT_COUNTER(name) c[#name] = status.counters.name;
    DRIVEBUS_SHM_BUS_COUNTERS(DRIVEBUS_MQTT_COUNTER)
#undef DRIVEBUS_MQTT_COUNTER
    j["counters"] = std::move(c);
    return j;
}

Json bus_unreachable(std::string_view bus, std::string_view why) {
    return Json{{"bus", std::string(bus)}, {"drivebusd", "unreachable"}, {"up", false}, {"error", std::string(why)}};
}

bool significant_change(const Json& published, const Json& now, double deadband) {
    return differs(published, now, deadband, false);
}

}  // namespace drivebus::mqtt
