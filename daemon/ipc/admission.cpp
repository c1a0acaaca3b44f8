#include "ipc/admission.hpp"

#include <algorithm>
#include <fmt/format.h>

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

// Inside one of the profile's indirect blocks for this function: the block's own rules apply
// (its slots stand for other registers), so the per-register checks are skipped.
bool in_block(const Profile& profile, std::uint8_t function, std::uint16_t start, std::uint16_t count) {
    const auto* block = profile.block(function);
    return block != nullptr && start == block->address && count >= block->min_quantity &&
           count <= block->max_quantity;
}

// A profile that lists no registers (generic) accepts any address.
std::expected<void, Rejection> check_readable(const Profile& profile, std::uint16_t start, std::uint16_t count) {
    if (profile.registers.empty() || in_block(profile, 3, start, count)) {
        return {};
    }
    if (const auto* block = profile.block(3); block != nullptr && start == block->address) {
        return reject(RejectReason::Quantity, fmt::format("the read block at {} takes {}-{} words", hex(start),
                                                          block->min_quantity, block->max_quantity));
    }
    for (std::uint32_t a = start; a < static_cast<std::uint32_t>(start) + count; ++a) {
        const auto address = static_cast<std::uint16_t>(a);
        const auto* r = profile.find(address);
        if (r == nullptr) {
            return reject(RejectReason::UnknownRegister,
                          fmt::format("register {} is not in profile {}", hex(address), profile.type), address);
        }
        if (!readable(r->access)) {
            return reject(RejectReason::WriteOnly, fmt::format("register {} is write-only", r->name), address);
        }
    }
    return {};
}

std::expected<void, Rejection> check_writable(const Profile& profile, const shm::Request& request,
                                              std::uint8_t function) {
    if (profile.registers.empty() || in_block(profile, function, request.start, request.count)) {
        return {};
    }
    for (std::size_t i = 0; i < request.count; ++i) {
        const auto address = static_cast<std::uint16_t>(request.start + i);
        const auto* r = profile.find(address);
        if (r == nullptr) {
            return reject(RejectReason::UnknownRegister,
                          fmt::format("register {} is not in profile {}", hex(address), profile.type), address);
        }
        if (!writable(r->access)) {
            return reject(RejectReason::ReadOnly, fmt::format("register {} is read-only", r->name), address);
        }
        if (!r->in_range(request.values.at(i))) {
            return reject(RejectReason::ValueOutOfRange,
                          fmt::format("{} = {} is outside the profile's range {}..{}", r->name, request.values.at(i),
                                      r->min.value_or(0), r->max.value_or(65535)),
                          address);
        }
    }
    return {};
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
    default:
        return reject(RejectReason::Malformed, "the request is not a valid Modbus request");
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

bool touches(const Profile& profile, std::uint16_t start, std::uint16_t count) {
    if (!profile.control) {
        return false;
    }
    return std::ranges::any_of(profile.control->lease_registers, [&](const std::string& name) {
        const auto* r = profile.find(name);
        return r != nullptr && r->address && *r->address >= start && *r->address < start + count;
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
    if (auto ok = check_writable(profile, request, function); !ok) {
        return std::unexpected(ok.error());
    }
    Admitted a{drive, {bus.drives[drive].address, write_pdu(request, function)}, true,
               touches(profile, request.start, request.count)};
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
    Admitted a{kBroadcast, {0, write_pdu(request, function)}, true, false};
    for (const auto& d : bus.drives) {
        const auto& profile = *d.profile;
        if (std::ranges::find(profile.functions.broadcast, function) == profile.functions.broadcast.end()) {
            return reject(RejectReason::Unsupported, fmt::format("drive {} (profile {}) does not take function {} "
                                                                 "as a broadcast",
                                                                 d.name, profile.type, function));
        }
        if (auto ok = check_writable(profile, request, function); !ok) {
            return std::unexpected(ok.error());
        }
        a.touches_control = a.touches_control || touches(profile, request.start, request.count);
    }
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
        return reject(RejectReason::Malformed, fmt::format("request version {} size {} (this drivebusd: {} / {})",
                                                           request.version, request.size, shm::kPayloadVersion,
                                                           sizeof(shm::Request)));
    }
    if (request.kind == shm::RequestKind::Broadcast) {
        return admit_broadcast(bus, request);
    }
    if (request.kind == shm::RequestKind::Probe) {
        if (request.address < 1 || request.address > 247) {
            return reject(RejectReason::UnknownDrive, fmt::format("address {} is outside 1-247", request.address));
        }
        return Admitted{find_drive(bus, request).value_or(kBroadcast),
                        {request.address, rtu::ReadHoldingRegisters{request.start, 1}}, true, false};
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
        if (auto ok = check_readable(*d.profile, request.start, request.count); !ok) {
            return std::unexpected(ok.error());
        }
        Admitted a{*drive, {d.address, rtu::ReadHoldingRegisters{request.start, request.count}}, true, false};
        if (auto ok = check_codec(a.request, *d.profile); !ok) {
            return std::unexpected(ok.error());
        }
        return a;
    }
    case shm::RequestKind::Write: return admit_write(bus, *drive, request);
    case shm::RequestKind::Identify: {
        Admitted a{*drive, {d.address, rtu::ReadDeviceIdentification{rtu::DeviceIdCode::Basic, 0}}, true, false};
        if (auto ok = check_codec(a.request, *d.profile); !ok) {
            return std::unexpected(ok.error());
        }
        return a;
    }
    case shm::RequestKind::LeaseRenew:
    case shm::RequestKind::LeaseRelease: return Admitted{*drive, {}, false, true};
    case shm::RequestKind::Broadcast:
    case shm::RequestKind::Probe: break;
    }
    return reject(RejectReason::Malformed, fmt::format("unknown request kind {}", static_cast<int>(request.kind)));
}

}  // namespace drivebus::ipc
