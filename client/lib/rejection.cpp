// SPDX-License-Identifier: Apache-2.0
// What a rejection says, in one line: the reason, and what the drive's profile tells about the
// register it names (drivebusd sends the reason and the register, not its own words).
#include <cstdio>

#include "bus_impl.hpp"

namespace drivebus {
namespace {

std::string hex(std::uint16_t address) {
    char text[8];
    std::snprintf(text, sizeof text, "0x%04X", address);
    return text;
}

std::string block_name(const IndirectBlock& block) {
    return std::string(block.function == 3 ? "the read block at " : "the write block at ") + hex(block.address);
}

// Registers drivebusd relies on: the selectors of the profile's indirect blocks, or a register
// its configuration writes when the drive comes online.
std::string owned(std::uint16_t address, const Profile* profile) {
    if (profile != nullptr) {
        for (const auto& block : profile->indirect_blocks) {
            for (const auto& selector : block.selectors) {
                const auto* r = profile->find(std::string_view(selector));
                if (r != nullptr && r->address == address) {
                    return r->name + " is owned by drivebusd: selector of " + block_name(block);
                }
            }
        }
        if (const auto* r = profile->find(address); r != nullptr) {
            return r->name + " is owned by drivebusd: it writes it when the drive comes online";
        }
    }
    return "register " + hex(address) + " is owned by drivebusd";
}

std::string not_set_up(std::uint16_t address, const Profile* profile) {
    const IndirectBlock* block = nullptr;
    if (profile != nullptr) {
        for (const auto& b : profile->indirect_blocks) {
            if (b.address == address) {
                block = &b;
            }
        }
    }
    if (block == nullptr) {
        return "the indirect block at " + hex(address) + " is not set up by drivebusd for this request";
    }
    return block_name(*block) + " is not set up by drivebusd for this request, so what it touches is unknown: " +
           (block->function == 3 ? "read the registers one by one (or poll them with indirect = true)"
                                 : "write the registers one by one (or name them in the drive's write_block)");
}

}  // namespace

std::string rejection_text(const shm::Response& r, const Profile* profile) {
    switch (r.reason) {
    case shm::RejectReason::DaemonOwned: return owned(r.register_address, profile);
    case shm::RejectReason::BlockNotSetUp: return not_set_up(r.register_address, profile);
    default: break;
    }
    const bool names_register = r.register_address != 0 || r.reason == shm::RejectReason::UnknownRegister ||
                                r.reason == shm::RejectReason::ReadOnly ||
                                r.reason == shm::RejectReason::ValueOutOfRange;
    return std::string(shm::to_string(r.reason)) +
           (names_register ? " (register " + hex(r.register_address) + ")" : std::string());
}

}  // namespace drivebus
