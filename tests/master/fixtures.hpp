// SPDX-License-Identifier: Apache-2.0
// Bus plans for the master's tests, built in code from the real profiles.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "master/bus_plan.hpp"

namespace drivebus::test {

inline std::shared_ptr<const Profile> load(std::string_view type) {
    auto p = load_profile_by_type(type);
    if (!p) {
        throw std::runtime_error(p.error().message);
    }
    return std::make_shared<const Profile>(std::move(*p));
}

inline master::PollGroup poll(const Profile& profile, std::vector<std::string> names, rtu::Duration period,
                              bool indirect = false) {
    master::PollGroup g;
    g.name = "g";
    g.period = period;
    g.indirect = indirect;
    for (auto& n : names) {
        const RegisterInfo* r = profile.find(n);
        if (r == nullptr || !r->address) {
            throw std::runtime_error("no register " + n);
        }
        g.registers.push_back({n, *r->address});
    }
    return g;
}

inline master::DrivePlan drive(std::string name, std::uint8_t address, std::shared_ptr<const Profile> profile) {
    master::DrivePlan d;
    d.name = std::move(name);
    d.address = address;
    d.profile = std::move(profile);
    return d;
}

// A bus plan, or (for the tests of the bus thread) a config::BusConfig, which is one.
template <class Bus = master::BusPlan>
Bus bus(rtu::LineFormat format = {19200, 8, rtu::Parity::None, 1}) {
    Bus b;
    b.name = "test";
    b.format = format;
    b.response_timeout = std::chrono::milliseconds(50);
    b.retries = 2;
    return b;
}

}  // namespace drivebus::test
