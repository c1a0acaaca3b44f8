// Bus configurations for the master's tests, built in code from the real profiles.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/config.hpp"

namespace drivebus::test {

inline std::shared_ptr<const Profile> load(std::string_view type) {
    auto p = load_profile_by_type(type);
    if (!p) {
        throw std::runtime_error(p.error().message);
    }
    return std::make_shared<const Profile>(std::move(*p));
}

inline config::PollGroup poll(const Profile& profile, std::vector<std::string> names, rtu::Duration period,
                              bool indirect = false) {
    config::PollGroup g;
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

inline config::DriveConfig drive(std::string name, std::uint8_t address, std::shared_ptr<const Profile> profile) {
    config::DriveConfig d;
    d.name = std::move(name);
    d.address = address;
    d.profile = std::move(profile);
    return d;
}

inline config::BusConfig bus(rtu::LineFormat format = {19200, 8, rtu::Parity::None, 1}) {
    config::BusConfig b;
    b.name = "test";
    b.device = "/dev/null";
    b.format = format;
    b.response_timeout = std::chrono::milliseconds(50);
    b.retries = 2;
    return b;
}

}  // namespace drivebus::test
