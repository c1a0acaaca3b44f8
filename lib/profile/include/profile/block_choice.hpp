// SPDX-License-Identifier: Apache-2.0
// Which code of an indirect block's selector picks a register: what the configuration checks
// and what the master writes at set-up, from one place.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "drivebus/profile.hpp"

namespace drivebus {

// The code of `block` that selects the register at `target`; nullopt when none does.
[[nodiscard]] inline std::optional<std::uint16_t> block_choice(const Profile& profile, const IndirectBlock& block,
                                                               std::uint16_t target) {
    for (const auto& [code, name] : block.choices) {
        const RegisterInfo* r = profile.find(std::string_view(name));
        if (r != nullptr && r->address == target) {
            return code;
        }
    }
    return std::nullopt;
}

}  // namespace drivebus
