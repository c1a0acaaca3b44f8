// SPDX-License-Identifier: Apache-2.0
// The configuration of the indirect blocks drivebusd sets up (the read block follows the
// drive's indirect poll, the write block its `write_block` key; master::block_setups() turns
// them into selector writes), and the start-up warnings of a valid configuration.
#include <algorithm>

#include "profile/block_choice.hpp"
#include "read.hpp"

namespace drivebus::config {

namespace detail {
namespace {

// The read block has one set of selectors: every indirect poll of a drive must read the same
// registers in the same order, or one of them would read what the other selected.
void check_indirect_polls(Section& s, const DriveConfig& drive) {
    const PollGroup* first = nullptr;
    for (const auto& poll : drive.polls) {
        if (!poll.indirect) {
            continue;
        }
        if (first == nullptr) {
            first = &poll;
            continue;
        }
        const auto same = std::ranges::equal(poll.registers, first->registers,
                                             [](const auto& a, const auto& b) { return a.address == b.address; });
        if (!same) {
            s.fail("poll " + in_quotes(poll.name) + " and poll " + in_quotes(first->name) +
                   " both read the indirect read block, which has one set of selectors: give them the same "
                   "registers in the same order, or read one group directly");
        }
    }
}

// `write_block = ["FA00", "FA01"]`: the registers the write block's slots select, in order.
std::optional<std::vector<std::uint16_t>> write_targets(Section& s, std::string_view key, const Profile& profile) {
    auto names = s.strings(key);
    if (!names) {
        return std::nullopt;
    }
    const auto* block = profile.block(16);
    const auto title = title_of(profile);
    if (block == nullptr) {
        s.fail("write_block is set, but " + title + " has no indirect write block");
        return std::nullopt;
    }
    if (names->size() < block->min_quantity || names->size() > block->max_quantity) {
        s.fail("write_block names " + std::to_string(names->size()) + " registers; the indirect write block of " +
               title + " takes " + std::to_string(block->min_quantity) + "-" + std::to_string(block->max_quantity));
        return std::nullopt;
    }
    std::vector<std::uint16_t> targets;
    for (const auto& name : *names) {
        const RegisterInfo* r = profile.find(std::string_view(name));
        if (r == nullptr || !r->address || !block_choice(profile, *block, *r->address)) {
            std::string choices;
            for (const auto& [code, choice] : block->choices) {
                choices.append(choices.empty() ? "" : ", ").append(choice);
            }
            s.fail("write_block " + in_quotes(name) + " is not one the indirect write block of " + title +
                   " can select (" + choices + ")");
            return std::nullopt;
        }
        if (std::ranges::find(targets, *r->address) != targets.end()) {
            s.fail("write_block names " + r->name + " twice");
            return std::nullopt;
        }
        targets.push_back(*r->address);
    }
    return targets;
}

}  // namespace

void read_blocks(Section& s, DriveConfig& drive, std::string_view write_block) {
    if (!drive.profile) {
        return;  // its loading failed and was reported
    }
    check_indirect_polls(s, drive);
    if (auto targets = write_targets(s, write_block, *drive.profile)) {
        drive.write_block = std::move(*targets);
    }
}

}  // namespace detail

std::vector<std::string> start_up_warnings(const Config& config) {
    std::vector<std::string> lines;
    for (const auto& bus : config.buses) {
        for (const auto& drive : bus.drives) {
            const ControlInfo* control = drive.profile && drive.profile->control ? &*drive.profile->control : nullptr;
            if (control == nullptr || control->lease_registers.empty() || control->stop || control->freewheel) {
                continue;
            }
            lines.push_back("bus " + detail::in_quotes(bus.name) + " drive " + detail::in_quotes(drive.name) +
                            ": profile " + detail::in_quotes(drive.profile->type) +
                            " gives no stop or freewheel command word, so its control lease can only fall back "
                            "to \"hold\": if the application holding the lease dies or hangs, the drive keeps "
                            "running at its last command; provide another way to stop it (a hardwired stop "
                            "circuit)");
        }
    }
    return lines;
}

}  // namespace drivebus::config
