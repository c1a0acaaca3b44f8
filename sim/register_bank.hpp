// SPDX-License-Identifier: Apache-2.0
// The registers of one simulated drive, built from its profile: values plus the profile's
// access and range, so that reads and writes fail the way the drive's documents say.
#pragma once

#include <cstdint>
#include <expected>
#include <map>
#include <string_view>

#include "drivebus/profile.hpp"
#include "rtu/types.hpp"

namespace drivebus::sim {

class RegisterBank {
public:
    explicit RegisterBank(const Profile& profile);

    // Master access: unknown or write-only registers give IllegalDataAddress.
    [[nodiscard]] std::expected<std::uint16_t, rtu::ExceptionCode> read(std::uint16_t address) const;
    // Master access: unknown or read-only registers give IllegalDataAddress, values outside
    // the profile's range IllegalDataValue.
    [[nodiscard]] std::expected<void, rtu::ExceptionCode> check_write(std::uint16_t address, std::uint16_t value) const;

    // The drive's own access, for values it computes (no access or range checks).
    [[nodiscard]] std::uint16_t get(std::uint16_t address) const noexcept;
    void put(std::uint16_t address, std::uint16_t value) noexcept;
    [[nodiscard]] bool contains(std::uint16_t address) const noexcept { return cells_.contains(address); }

    [[nodiscard]] const Profile& profile() const noexcept { return *profile_; }

private:
    struct Cell {
        const RegisterInfo* info = nullptr;
        std::uint16_t value = 0;
    };
    const Profile* profile_;
    std::map<std::uint16_t, Cell> cells_;
};

}  // namespace drivebus::sim
