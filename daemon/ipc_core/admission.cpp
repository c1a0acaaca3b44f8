// SPDX-License-Identifier: Apache-2.0
#include "ipc/admission.hpp"

#include <fmt/format.h>
#include <algorithm>

#include "master/block_setup.hpp"
#include "master/scheduler.hpp"
#include "rtu/codec.hpp"

namespace drivebus::ipc {
namespace {

using shm::RejectReason;

std::unexpected<Rejection> reject(RejectReason reason, std::string why, std::uint16_t address = 0) {
    return std::unexpected(Rejection{reason, address, std::move(why)});
}

std::string hex(std::uint16_t address) {
    return fmt::format("0x{:04X}", address);
}

// A request at the address of one of the profile's indirect blocks for this function, with a
// quantity the block takes: its slots stand for the registers the selectors chose.
bool in_block(const Profile& profile, std::uint8_t function, std::uint16_t start, std::uint16_t count) {
    const auto* block = profile.block(function);
    return block != nullptr && start == block->address && count >= block->min_quantity && count <= block->max_quantity;
}

std::string_view block_kind(const IndirectBlock& block) {
    return block.function == 3 ? "read" : "write";
}

std::string name_of(const Profile& profile, std::uint16_t address) {
    const auto* r = profile.find(address);
    return r != nullptr ? r->name : hex(address);
}

// The registers drivebusd relies on are its own: a client that rewrote a block's selector
// would make every later read of the block (and every snapshot built from it) report one
// register's value under another's name. Every selector of the profile's blocks is owned,
// whether or not this drive's configuration uses the block: a client can reach a block only
// through selectors drivebusd wrote (block_targets), so nothing of a client's would use them.
std::expected<void, Rejection> check_not_owned(const config::DriveConfig& drive, std::uint16_t address) {
    const Profile& profile = *drive.profile;
    for (const auto& block : profile.indirect_blocks) {
        for (const auto& selector : block.selectors) {
            const auto* r = profile.find(std::string_view(selector));
            if (r != nullptr && r->address == address) {
                return reject(RejectReason::DaemonOwned,
                              fmt::format("{} is owned by drivebusd: selector of the {} block at {}", r->name,
                                          block_kind(block), hex(block.address)),
                              address);
            }
        }
    }
    for (const auto& [reg, value] : master::setup_writes(drive)) {
        if (reg == address) {
            return reject(RejectReason::DaemonOwned,
                          fmt::format("{} is owned by drivebusd: it writes {} there when drive {} comes online",
                                      name_of(profile, address), value, drive.name),
                          address);
        }
    }
    return {};
}

// The registers `count` slots of `block` stand for, as drivebusd set the block up on this
// drive. Only drivebusd writes the selectors, so only its set-up says what the block touches;
// without it, no rule could be checked, and the access is refused.
std::expected<std::vector<std::uint16_t>, Rejection> block_targets(const config::DriveConfig& drive,
                                                                   const IndirectBlock& block, std::uint16_t count) {
    const auto blocks = master::block_setups(drive);
    const auto* setup = master::find_block(blocks, block.function);
    const auto what = fmt::format("the {} block at {}", block_kind(block), hex(block.address));
    const auto instead = block.function == 3 ? "read the registers one by one, or poll them with indirect = true"
                                             : "write the registers one by one, or name them in the drive's "
                                               "write_block";
    if (setup == nullptr) {
        return reject(RejectReason::BlockNotSetUp,
                      fmt::format("{} is not set up by drivebusd on drive {}, so what it touches is unknown: {}", what,
                                  drive.name, instead),
                      block.address);
    }
    std::vector<std::uint16_t> targets;
    for (std::size_t slot = 0; slot < count; ++slot) {
        if (slot >= setup->slots.size() || !setup->slots[slot].target) {
            return reject(RejectReason::BlockNotSetUp,
                          fmt::format("slot {} of {} selects nothing as drivebusd set it up on drive {}: {}", slot + 1,
                                      what, drive.name, instead),
                          block.address);
        }
        targets.push_back(*setup->slots[slot].target);
    }
    return targets;
}

std::vector<std::uint16_t> addresses(std::uint16_t start, std::uint16_t count) {
    std::vector<std::uint16_t> out;
    for (std::uint32_t a = start; a < static_cast<std::uint32_t>(start) + count; ++a) {
        out.push_back(static_cast<std::uint16_t>(a));
    }
    return out;
}

// The registers a read touches. A profile that lists no registers (generic) accepts any address.
std::expected<std::vector<std::uint16_t>, Rejection> check_readable(const config::DriveConfig& drive,
                                                                    std::uint16_t start, std::uint16_t count) {
    const Profile& profile = *drive.profile;
    const auto* block = profile.block(3);
    if (in_block(profile, 3, start, count)) {
        auto targets = block_targets(drive, *block, count);
        if (!targets) {
            return std::unexpected(targets.error());
        }
        for (const auto target : *targets) {
            if (const auto* r = profile.find(target); r != nullptr && !readable(r->access)) {
                return reject(RejectReason::WriteOnly, fmt::format("register {} is write-only", r->name), target);
            }
        }
        return targets;
    }
    if (profile.registers.empty()) {
        return addresses(start, count);
    }
    if (block != nullptr && start == block->address) {
        return reject(RejectReason::Quantity, fmt::format("the read block at {} takes {}-{} words", hex(start),
                                                          block->min_quantity, block->max_quantity));
    }
    for (const auto address : addresses(start, count)) {
        const auto* r = profile.find(address);
        if (r == nullptr) {
            return reject(RejectReason::UnknownRegister,
                          fmt::format("register {} is not in profile {}", hex(address), profile.type), address);
        }
        if (!readable(r->access)) {
            return reject(RejectReason::WriteOnly, fmt::format("register {} is write-only", r->name), address);
        }
    }
    return addresses(start, count);
}

// Writable, in range and not drivebusd's: each register the write reaches (through a block,
// each register its slots select). A profile that lists no registers (generic) accepts any.
std::expected<void, Rejection> check_register(const config::DriveConfig& drive, std::uint16_t address,
                                              std::uint16_t value) {
    if (auto ok = check_not_owned(drive, address); !ok) {
        return ok;
    }
    const Profile& profile = *drive.profile;
    if (profile.registers.empty()) {
        return {};
    }
    const auto* r = profile.find(address);
    if (r == nullptr) {
        return reject(RejectReason::UnknownRegister,
                      fmt::format("register {} is not in profile {}", hex(address), profile.type), address);
    }
    if (!writable(r->access)) {
        return reject(RejectReason::ReadOnly, fmt::format("register {} is read-only", r->name), address);
    }
    if (!r->in_range(value)) {
        return reject(RejectReason::ValueOutOfRange,
                      fmt::format("{} = {} is outside the profile's range {}..{}", r->name, value, r->min.value_or(0),
                                  r->max.value_or(65535)),
                      address);
    }
    return {};
}

// The registers a write touches, each checked.
std::expected<std::vector<std::uint16_t>, Rejection> check_writable(const config::DriveConfig& drive,
                                                                    const shm::Request& request,
                                                                    std::uint8_t function) {
    const Profile& profile = *drive.profile;
    std::vector<std::uint16_t> targets = addresses(request.start, request.count);
    if (in_block(profile, function, request.start, request.count)) {
        auto selected = block_targets(drive, *profile.block(function), request.count);
        if (!selected) {
            return std::unexpected(selected.error());
        }
        targets = std::move(*selected);
    }
    for (std::size_t i = 0; i < targets.size(); ++i) {
        if (auto ok = check_register(drive, targets[i], request.values.at(i)); !ok) {
            return std::unexpected(ok.error());
        }
    }
    return targets;
}

std::expected<void, Rejection> check_codec(const rtu::RequestAdu& adu, const Profile& profile) {
    const auto valid = rtu::validate_request(adu, master::limits_of(profile));
    if (valid) {
        return {};
    }
    switch (valid.error()) {
    case rtu::ValidationError::FunctionNotSupported:
    case rtu::ValidationError::BroadcastNotAllowed:
        return reject(RejectReason::Unsupported, fmt::format("profile {} does not support function {}", profile.type,
                                                             static_cast<int>(rtu::function_of(adu.pdu))));
    case rtu::ValidationError::QuantityOutOfRange:
    case rtu::ValidationError::QuantityAboveDriveLimit:
    case rtu::ValidationError::AddressRangeOverflow:
    case rtu::ValidationError::AduTooLong:
        return reject(RejectReason::Quantity, fmt::format("quantity out of range for profile {}", profile.type));
    default: return reject(RejectReason::Malformed, "the request is not a valid Modbus request");
    }
}

std::uint8_t write_function(const shm::Request& request) {
    if (request.function != 0) {
        return request.function;
    }
    return request.count == 1 ? 6 : 16;
}

rtu::Request write_pdu(const shm::Request& request, std::uint8_t function) {
    if (function == 6) {
        return rtu::WriteSingleRegister{request.start, request.values.at(0)};
    }
    return rtu::WriteMultipleRegisters{request.start,
                                       rtu::RegisterValues(std::span(request.values.data(), request.count))};
}

// Whether the registers written include the command or the reference (through a block too:
// the lease is about what reaches the drive, not about the address in the request).
bool touches(const Profile& profile, const std::vector<std::uint16_t>& written) {
    if (!profile.control) {
        return false;
    }
    return std::ranges::any_of(profile.control->lease_registers, [&](const std::string& name) {
        const auto* r = profile.find(name);
        return r != nullptr && r->address && std::ranges::find(written, *r->address) != written.end();
    });
}

std::expected<Admitted, Rejection> admit_write(const config::BusConfig& bus, std::size_t drive,
                                               const shm::Request& request) {
    const auto& profile = *bus.drives[drive].profile;
    if (request.count == 0 || request.count > shm::kMaxWriteWords) {
        return reject(RejectReason::Quantity, fmt::format("a write carries 1-{} words", shm::kMaxWriteWords));
    }
    const auto function = write_function(request);
    if (function != 6 && function != 16) {
        return reject(RejectReason::Unsupported, fmt::format("function {} is not a write", function));
    }
    if (function == 6 && request.count != 1) {
        return reject(RejectReason::Quantity, "function 6 writes exactly one word");
    }
    auto written = check_writable(bus.drives[drive], request, function);
    if (!written) {
        return std::unexpected(written.error());
    }
    Admitted a{
        drive, {bus.drives[drive].address, write_pdu(request, function)}, true, touches(profile, *written), *written};
    if (auto ok = check_codec(a.request, profile); !ok) {
        return std::unexpected(ok.error());
    }
    return a;
}

std::expected<Admitted, Rejection> admit_broadcast(const config::BusConfig& bus, const shm::Request& request) {
    if (request.count == 0 || request.count > shm::kMaxWriteWords) {
        return reject(RejectReason::Quantity, fmt::format("a write carries 1-{} words", shm::kMaxWriteWords));
    }
    const auto function = write_function(request);
    Admitted a{kBroadcast, {0, write_pdu(request, function)}, true, false, {}};
    for (const auto& d : bus.drives) {
        const auto& profile = *d.profile;
        if (std::ranges::find(profile.functions.broadcast, function) == profile.functions.broadcast.end()) {
            return reject(RejectReason::Unsupported, fmt::format("drive {} (profile {}) does not take function {} "
                                                                 "as a broadcast",
                                                                 d.name, profile.type, function));
        }
        const auto written = check_writable(d, request, function);
        if (!written) {
            return std::unexpected(written.error());
        }
        a.touches_control = a.touches_control || touches(profile, *written);
        a.registers.insert(a.registers.end(), written->begin(), written->end());
    }
    std::ranges::sort(a.registers);
    const auto [first, last] = std::ranges::unique(a.registers);
    a.registers.erase(first, last);
    if (const auto valid = rtu::validate_request(a.request); !valid) {
        return reject(RejectReason::Quantity, "the broadcast is not a valid Modbus request");
    }
    return a;
}

}  // namespace

std::optional<std::size_t> find_drive(const config::BusConfig& bus, const shm::Request& request) {
    const auto name = shm::view(request.drive);
    for (std::size_t i = 0; i < bus.drives.size(); ++i) {
        if (name.empty() ? bus.drives[i].address == request.address : bus.drives[i].name == name) {
            return i;
        }
    }
    return std::nullopt;
}

std::expected<Admitted, Rejection> admit(const config::BusConfig& bus, const shm::Request& request) {
    if (!shm::compatible(request)) {
        return reject(RejectReason::Malformed,
                      fmt::format("request version {} size {} (this drivebusd: {} / {})", request.version, request.size,
                                  shm::kPayloadVersion, sizeof(shm::Request)));
    }
    if (request.kind == shm::RequestKind::Broadcast) {
        return admit_broadcast(bus, request);
    }
    if (request.kind == shm::RequestKind::Probe) {
        if (request.address < 1 || request.address > 247) {
            return reject(RejectReason::UnknownDrive, fmt::format("address {} is outside 1-247", request.address));
        }
        return Admitted{find_drive(bus, request).value_or(kBroadcast),
                        {request.address, rtu::ReadHoldingRegisters{request.start, 1}},
                        true,
                        false,
                        {request.start}};
    }
    const auto drive = find_drive(bus, request);
    if (!drive) {
        const auto name = shm::view(request.drive);
        return reject(RejectReason::UnknownDrive,
                      name.empty() ? fmt::format("no drive at address {} on bus {}", request.address, bus.name)
                                   : fmt::format("no drive named {} on bus {}", name, bus.name));
    }
    const auto& d = bus.drives[*drive];
    switch (request.kind) {
    case shm::RequestKind::Read: {
        if (request.count == 0 || request.count > shm::kMaxReadWords) {
            return reject(RejectReason::Quantity, fmt::format("a read asks for 1-{} words", shm::kMaxReadWords));
        }
        auto read = check_readable(d, request.start, request.count);
        if (!read) {
            return std::unexpected(read.error());
        }
        Admitted a{*drive,
                   {d.address, rtu::ReadHoldingRegisters{request.start, request.count}},
                   true,
                   false,
                   std::move(*read)};
        if (auto ok = check_codec(a.request, *d.profile); !ok) {
            return std::unexpected(ok.error());
        }
        return a;
    }
    case shm::RequestKind::Write: return admit_write(bus, *drive, request);
    case shm::RequestKind::Identify: {
        Admitted a{*drive, {d.address, rtu::ReadDeviceIdentification{rtu::DeviceIdCode::Basic, 0}}, true, false, {}};
        if (auto ok = check_codec(a.request, *d.profile); !ok) {
            return std::unexpected(ok.error());
        }
        return a;
    }
    case shm::RequestKind::LeaseRenew:
    case shm::RequestKind::LeaseRelease: return Admitted{*drive, {}, false, true, {}};
    case shm::RequestKind::Broadcast:
    case shm::RequestKind::Probe:
    case shm::RequestKind::Withdraw: break;  // the intake's own, never admitted to the bus
    }
    return reject(RejectReason::Malformed, fmt::format("unknown request kind {}", static_cast<int>(request.kind)));
}

}  // namespace drivebus::ipc
