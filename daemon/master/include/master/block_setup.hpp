// SPDX-License-Identifier: Apache-2.0
// The indirect blocks drivebusd sets up on a drive, and the selector writes that set them up.
// drivebusd alone writes a block's selectors, so it alone knows what the block touches: the
// scheduler sends these writes when the drive comes online, and admission checks every client
// request through a block against the same targets (docs/ipc.md). Pure.
#pragma once

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "master/bus_plan.hpp"

namespace drivebus::master {

// One slot of an indirect block as drivebusd sets it up: the selector parameter, the value
// drivebusd writes to it when the drive comes online, and the register that value selects.
struct BlockSlot {
    std::optional<std::uint16_t> selector;  // its register (ATV21 F875: 0x0875); nullopt: the profile gives none
    std::uint16_t value = 0;                // 0 selects nothing
    std::optional<std::uint16_t> target;    // the register selected; nullopt for 0
};

// An indirect block drivebusd sets up on a drive, every selector of the profile's block in slot
// order. drivebusd alone writes these selectors, so it alone knows what the block touches:
// client requests through the block are admitted by its targets (ipc/admission).
struct BlockSetup {
    std::uint8_t function = 3;  // 3: the read block, 16: the write block
    std::uint16_t address = 0;  // where it is read or written (ATV21: 0x1875, 0x1870)
    std::vector<BlockSlot> slots;
};

// The blocks drivebusd sets up on `drive`: the read block for its (first) indirect poll, the
// write block for its `write_block`. Derived from the configuration alone, so the scheduler and
// admission cannot disagree.
[[nodiscard]] std::vector<BlockSetup> block_setups(const DrivePlan& drive);
// The block of `blocks` for `function` (3 or 16), if set up.
[[nodiscard]] const BlockSetup* find_block(const std::vector<BlockSetup>& blocks, std::uint8_t function) noexcept;
// The writes drivebusd makes to a drive when it comes online, in order: (register, value).
[[nodiscard]] std::vector<std::pair<std::uint16_t, std::uint16_t>> setup_writes(const DrivePlan& drive);

}  // namespace drivebus::master
