// SPDX-License-Identifier: Apache-2.0
// The profile's [safety] table: the drive's own Modbus time-out and what it does when it fires.
// read_safety() checks the table's own keys; check_safety() the registers it names, once they
// are all read.
#include <array>
#include <cmath>
#include <utility>

#include "parse_sections.hpp"

namespace drivebus::profile_detail {
namespace {

// What one raw count of a time-out register can be.
constexpr std::array<std::pair<std::string_view, double>, 5> kUnits = {
    {{"ms", 0.001}, {"0.01s", 0.01}, {"0.1s", 0.1}, {"s", 1.0}, {"min", 60.0}}};

std::optional<double> unit_seconds(std::string_view unit) {
    for (const auto& [name, seconds] : kUnits) {
        if (name == unit) {
            return seconds;
        }
    }
    return std::nullopt;
}

// The seconds per count a register's own unit and scale give, when its unit is a time.
std::optional<double> register_seconds(const RegisterInfo& r) {
    if (r.unit == "s") {
        return r.scale;
    }
    if (r.unit == "ms") {
        return r.scale / 1000.0;
    }
    if (r.unit == "min") {
        return r.scale * 60.0;
    }
    return std::nullopt;
}

}  // namespace

void read_safety(const toml::table& table, Errors& errors, SafetyInfo& safety) {
    Section s(table, "safety", errors);
    s.allow_only({"comm_timeout", "comm_timeout_unit", "comm_timeout_off", "comm_fault_action"});
    safety.comm_timeout = s.string("comm_timeout").value_or("");
    safety.comm_fault_action = s.string("comm_fault_action").value_or("");
    const auto unit = s.string("comm_timeout_unit");
    if (unit) {
        if (const auto seconds = unit_seconds(*unit)) {
            safety.comm_timeout_seconds = *seconds;
        } else {
            s.fail("comm_timeout_unit " + in_quotes(*unit) + " is not one of ms, 0.01s, 0.1s, s, min");
        }
    }
    if (const auto off = s.integer("comm_timeout_off", 0, 0xFFFF)) {
        safety.comm_timeout_off = static_cast<std::uint16_t>(*off);
    }
    if (safety.comm_timeout.empty() && (unit || safety.comm_timeout_off)) {
        s.fail("comm_timeout_unit and comm_timeout_off describe comm_timeout, which is not given");
    }
    if (!safety.comm_timeout.empty() && !unit) {
        s.fail("comm_timeout is given without comm_timeout_unit (ms, 0.01s, 0.1s, s or min)");
    }
}

void check_safety(Profile& profile, Errors& errors) {
    if (!profile.safety) {
        return;
    }
    auto& safety = *profile.safety;
    // Both are read by drivebusd over Modbus: they need an address and must be readable.
    const auto fix = [&](std::string& name, std::string_view key) -> const RegisterInfo* {
        if (name.empty()) {
            return nullptr;
        }
        const auto* r = profile.find(name);
        if (r == nullptr || !r->address) {
            errors.add("safety", std::string(key) + " " + in_quotes(name) +
                                     (r == nullptr ? " is not a register of this profile" : " has no address"));
            return nullptr;
        }
        if (!readable(r->access)) {
            errors.add("safety", std::string(key) + " " + in_quotes(name) + " is not readable");
            return nullptr;
        }
        name = r->name;
        return r;
    };
    fix(safety.comm_fault_action, "comm_fault_action");
    const auto* timeout = fix(safety.comm_timeout, "comm_timeout");
    if (timeout == nullptr) {
        return;
    }
    if (const auto own = register_seconds(*timeout);
        own && std::abs(*own - safety.comm_timeout_seconds) > 1e-9 * safety.comm_timeout_seconds) {
        errors.add("safety", "comm_timeout_unit disagrees with register " + timeout->name + "'s unit \"" +
                                 timeout->unit + "\" and scale " + number_text(timeout->scale));
    } else if (!own && !timeout->unit.empty()) {
        errors.add("safety",
                   "comm_timeout " + in_quotes(timeout->name) + " has unit \"" + timeout->unit + "\", not a time");
    }
    if (safety.comm_timeout_off && !timeout->in_range(*safety.comm_timeout_off)) {
        errors.add("safety", "comm_timeout_off " + std::to_string(*safety.comm_timeout_off) + " is outside register " +
                                 timeout->name + "'s range");
    }
}

}  // namespace drivebus::profile_detail

namespace drivebus {

std::uint32_t SafetyInfo::milliseconds(std::uint16_t raw) const noexcept {
    if (comm_timeout_off && raw == *comm_timeout_off) {
        return 0;
    }
    return static_cast<std::uint32_t>(std::lround(static_cast<double>(raw) * comm_timeout_seconds * 1000.0));
}

}  // namespace drivebus
