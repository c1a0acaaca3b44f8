// SPDX-License-Identifier: Apache-2.0
// Read planning: what transactions a poll group needs within the drive's limits. Pure.
#include <algorithm>

#include "master/scheduler.hpp"

namespace drivebus::master {
namespace {

constexpr rtu::FunctionCode kRead = rtu::FunctionCode::ReadHoldingRegisters;

}  // namespace

rtu::FunctionLimits limits_of(const Profile& profile) {
    rtu::FunctionLimits limits;
    limits.max_address = profile.address_max;
    limits.max_read = profile.functions.read_holding_max;
    limits.max_write = profile.functions.write_multiple_max;
    limits.write_single = profile.functions.write_single;
    limits.device_identification = profile.functions.device_identification;
    const auto& broadcast = profile.functions.broadcast;
    limits.broadcast_write_single = std::ranges::find(broadcast, std::uint8_t{6}) != broadcast.end();
    limits.broadcast_write_multiple = std::ranges::find(broadcast, std::uint8_t{16}) != broadcast.end();
    for (const auto& block : profile.indirect_blocks) {
        limits.windows.push_back({block.function == 3 ? kRead : rtu::FunctionCode::WriteMultipleRegisters,
                                  block.address, block.min_quantity, block.max_quantity});
    }
    return limits;
}

std::vector<ReadChunk> plan_reads(const PollGroup& group, const Profile& profile, const rtu::FunctionLimits& limits) {
    std::vector<ReadChunk> chunks;
    if (group.indirect) {
        if (const IndirectBlock* block = profile.block(3)) {
            ReadChunk chunk{block->address, static_cast<std::uint16_t>(group.registers.size()), {}};
            for (const auto& r : group.registers) {
                chunk.addresses.push_back(r.address);
            }
            chunks.push_back(std::move(chunk));
        }
        return chunks;
    }
    // Consecutive registers share a transaction up to the drive's plain read limit.
    const std::uint16_t max = std::max<std::uint16_t>(1, limits.max_read);
    for (const auto& r : group.registers) {
        if (!chunks.empty()) {
            ReadChunk& last = chunks.back();
            if (r.address == static_cast<std::uint16_t>(last.start + last.quantity) && last.quantity < max &&
                last.start + last.quantity <= 0xFFFF) {
                ++last.quantity;
                last.addresses.push_back(r.address);
                continue;
            }
        }
        chunks.push_back(ReadChunk{r.address, 1, {r.address}});
    }
    return chunks;
}

}  // namespace drivebus::master
