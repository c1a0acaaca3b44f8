// SPDX-License-Identifier: Apache-2.0
// Test helpers: drives built from the real profiles, requests sent as frames.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "bus.hpp"
#include "drivebus/profile.hpp"
#include "rtu/codec.hpp"

namespace drivebus::sim::test {

inline std::shared_ptr<const Profile> profile(std::string_view type) {
    auto loaded = load_profile_by_type(type);
    if (!loaded) {
        throw std::runtime_error(loaded.error().message);
    }
    return std::make_shared<const Profile>(std::move(*loaded));
}

inline rtu::Instant at(double seconds) {
    return rtu::Instant{std::chrono::duration_cast<rtu::Duration>(std::chrono::duration<double>(1000.0 + seconds))};
}

// Sends a request to a drive and returns its reply (as the drive built it).
inline rtu::Response ask(ProfileDrive& drive, const rtu::Request& request, rtu::Instant now) {
    return drive.handle(request, false, now);
}

inline std::uint16_t read_one(ProfileDrive& drive, std::uint16_t address, rtu::Instant now) {
    const auto reply = ask(drive, rtu::ReadHoldingRegisters{address, 1}, now);
    const auto* words = std::get_if<rtu::ReadHoldingRegistersResponse>(&reply);
    if (words == nullptr || words->values.size() != 1) {
        ADD_FAILURE() << "read of 0x" << std::hex << address << " did not return one word";
        return 0;
    }
    return words->values[0];
}

inline std::optional<rtu::ExceptionCode> exception_of(const rtu::Response& reply) {
    if (const auto* e = std::get_if<rtu::ExceptionResponse>(&reply)) {
        return e->code;
    }
    return std::nullopt;
}

}  // namespace drivebus::sim::test
