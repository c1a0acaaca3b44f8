// SPDX-License-Identifier: Apache-2.0
#include "master/block_setup.hpp"

#include <algorithm>

#include "profile/block_choice.hpp"

namespace drivebus::master {
namespace {

// Every selector of `block`, the first ones pointing at `targets` (already checked to be choices
// of the block), the rest at nothing.
BlockSetup set_up(const Profile& profile, const IndirectBlock& block, const std::vector<std::uint16_t>& targets) {
    BlockSetup setup{block.function, block.address, {}};
    for (std::size_t slot = 0; slot < block.selectors.size(); ++slot) {
        const RegisterInfo* selector = profile.find(std::string_view(block.selectors[slot]));
        BlockSlot s{selector != nullptr ? selector->address : std::nullopt, 0, std::nullopt};
        // A selector with no Modbus address cannot be written: what its slot holds is unknown.
        if (slot < targets.size() && s.selector) {
            s.value = block_choice(profile, block, targets[slot]).value_or(0);
            s.target = s.value != 0 ? std::optional(targets[slot]) : std::nullopt;
        }
        setup.slots.push_back(s);
    }
    return setup;
}

}  // namespace

std::vector<BlockSetup> block_setups(const DrivePlan& drive) {
    std::vector<BlockSetup> blocks;
    if (!drive.profile) {
        return blocks;
    }
    const Profile& profile = *drive.profile;
    const auto poll = std::ranges::find_if(drive.polls, &PollGroup::indirect);
    if (const IndirectBlock* block = profile.block(3); block != nullptr && poll != drive.polls.end()) {
        std::vector<std::uint16_t> targets;
        for (const auto& r : poll->registers) {
            targets.push_back(r.address);
        }
        blocks.push_back(set_up(profile, *block, targets));
    }
    if (const IndirectBlock* block = profile.block(16); block != nullptr && !drive.write_block.empty()) {
        blocks.push_back(set_up(profile, *block, drive.write_block));
    }
    return blocks;
}

const BlockSetup* find_block(const std::vector<BlockSetup>& blocks, std::uint8_t function) noexcept {
    const auto it = std::ranges::find(blocks, function, &BlockSetup::function);
    return it != blocks.end() ? &*it : nullptr;
}

std::vector<std::pair<std::uint16_t, std::uint16_t>> setup_writes(const DrivePlan& drive) {
    std::vector<std::pair<std::uint16_t, std::uint16_t>> writes;
    for (const auto& block : block_setups(drive)) {
        for (const auto& slot : block.slots) {
            if (slot.selector) {
                writes.emplace_back(*slot.selector, slot.value);
            }
        }
    }
    return writes;
}

}  // namespace drivebus::master
