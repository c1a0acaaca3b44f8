// SPDX-License-Identifier: Apache-2.0
#include "register_bank.hpp"

namespace drivebus::sim {

RegisterBank::RegisterBank(const Profile& profile) : profile_(&profile) {
    for (const RegisterInfo& info : profile.registers) {
        if (!info.address) {
            continue;  // a parameter with no communication number cannot be reached over Modbus
        }
        const auto initial = static_cast<std::uint16_t>(info.default_value.value_or(0));
        cells_[*info.address] = Cell{&info, initial};
    }
}

std::expected<std::uint16_t, rtu::ExceptionCode> RegisterBank::read(std::uint16_t address) const {
    const auto it = cells_.find(address);
    if (it == cells_.end() || !readable(it->second.info->access)) {
        return std::unexpected(rtu::ExceptionCode::IllegalDataAddress);
    }
    return it->second.value;
}

std::expected<void, rtu::ExceptionCode> RegisterBank::check_write(std::uint16_t address, std::uint16_t value) const {
    const auto it = cells_.find(address);
    if (it == cells_.end() || !writable(it->second.info->access)) {
        return std::unexpected(rtu::ExceptionCode::IllegalDataAddress);
    }
    if (!it->second.info->in_range(value)) {
        return std::unexpected(rtu::ExceptionCode::IllegalDataValue);
    }
    return {};
}

std::uint16_t RegisterBank::get(std::uint16_t address) const noexcept {
    const auto it = cells_.find(address);
    return it == cells_.end() ? 0 : it->second.value;
}

void RegisterBank::put(std::uint16_t address, std::uint16_t value) noexcept {
    const auto it = cells_.find(address);
    if (it != cells_.end()) {
        it->second.value = value;
    }
}

}  // namespace drivebus::sim
