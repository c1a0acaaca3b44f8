// SPDX-License-Identifier: Apache-2.0
#include "gateway/pdu.hpp"

#include <algorithm>

namespace drivebus::gateway {
namespace {

constexpr std::size_t kMaxReadCount = 125;    // FC03/04
constexpr std::size_t kMaxWriteCount = 123;   // FC16
constexpr std::size_t kMaxObjectBytes = 240;  // what an FC43/14 answer carries at most

std::uint16_t be16(std::span<const std::uint8_t> pdu, std::size_t at) noexcept {
    return static_cast<std::uint16_t>((pdu[at] << 8) | pdu[at + 1]);
}

void push16(std::vector<std::uint8_t>& out, std::uint16_t value) {
    out.push_back(static_cast<std::uint8_t>(value >> 8));
    out.push_back(static_cast<std::uint8_t>(value & 0xFF));
}

std::unexpected<Refusal> refuse(std::uint8_t function, Exception code) {
    return std::unexpected(Refusal{function, code});
}

std::expected<Call, Refusal> parse_read(std::span<const std::uint8_t> pdu) {
    const std::uint8_t fc = pdu[0];
    if (pdu.size() != 5) {
        return refuse(fc, Exception::IllegalDataValue);
    }
    const ReadRegisters read{fc, be16(pdu, 1), be16(pdu, 3)};
    if (read.count == 0 || read.count > kMaxReadCount) {
        return refuse(fc, Exception::IllegalDataValue);
    }
    if (std::size_t{read.start} + read.count > 0x10000) {
        return refuse(fc, Exception::IllegalDataAddress);
    }
    return read;
}

std::expected<Call, Refusal> parse_write_single(std::span<const std::uint8_t> pdu) {
    if (pdu.size() != 5) {
        return refuse(kWriteSingle, Exception::IllegalDataValue);
    }
    return WriteRegisters{kWriteSingle, be16(pdu, 1), {be16(pdu, 3)}};
}

std::expected<Call, Refusal> parse_write_multiple(std::span<const std::uint8_t> pdu) {
    if (pdu.size() < 6) {
        return refuse(kWriteMultiple, Exception::IllegalDataValue);
    }
    const std::uint16_t start = be16(pdu, 1);
    const std::uint16_t count = be16(pdu, 3);
    const std::size_t bytes = pdu[5];
    if (count == 0 || count > kMaxWriteCount || bytes != 2U * count || pdu.size() != 6 + bytes) {
        return refuse(kWriteMultiple, Exception::IllegalDataValue);
    }
    if (std::size_t{start} + count > 0x10000) {
        return refuse(kWriteMultiple, Exception::IllegalDataAddress);
    }
    WriteRegisters write{kWriteMultiple, start, {}};
    write.values.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
        write.values.push_back(be16(pdu, 6 + 2 * i));
    }
    return write;
}

std::expected<Call, Refusal> parse_device_id(std::span<const std::uint8_t> pdu) {
    if (pdu.size() < 2 || pdu[1] != kMeiDeviceId) {
        return refuse(kEncapsulated, Exception::IllegalFunction);  // CANopen (0x0D) or another MEI type
    }
    if (pdu.size() != 4) {
        return refuse(kEncapsulated, Exception::IllegalDataValue);
    }
    const ReadDeviceId id{pdu[2], pdu[3]};
    // Only the basic objects (0 vendor, 1 product code, 2 revision) exist: codes 2 and 3 ask
    // for the regular and extended categories.
    if (id.code != 1 && id.code != 4) {
        return refuse(kEncapsulated, Exception::IllegalDataValue);
    }
    if (id.code == 4 && id.object > 2) {
        return refuse(kEncapsulated, Exception::IllegalDataAddress);
    }
    return id;
}

std::expected<Call, Refusal> parse_diagnostic(std::span<const std::uint8_t> pdu) {
    if (pdu.size() < 5) {
        return refuse(kDiagnostics, Exception::IllegalDataValue);
    }
    return Diagnostic{be16(pdu, 1), std::vector<std::uint8_t>(pdu.begin() + 3, pdu.end())};
}

}  // namespace

const char* to_string(Exception code) noexcept {
    switch (code) {
    case Exception::IllegalFunction: return "illegal function";
    case Exception::IllegalDataAddress: return "illegal data address";
    case Exception::IllegalDataValue: return "illegal data value";
    case Exception::ServerDeviceFailure: return "server device failure";
    case Exception::ServerDeviceBusy: return "server device busy";
    case Exception::GatewayPathUnavailable: return "gateway path unavailable";
    case Exception::GatewayTargetFailed: return "gateway target device failed to respond";
    }
    return "undefined exception";
}

std::expected<Call, Refusal> parse_request(std::span<const std::uint8_t> pdu) {
    if (pdu.empty()) {
        return refuse(0, Exception::IllegalFunction);
    }
    switch (pdu[0]) {
    case kReadHolding:
    case kReadInput: return parse_read(pdu);
    case kWriteSingle: return parse_write_single(pdu);
    case kWriteMultiple: return parse_write_multiple(pdu);
    case kEncapsulated: return parse_device_id(pdu);
    case kDiagnostics: return parse_diagnostic(pdu);
    default: return refuse(pdu[0], Exception::IllegalFunction);
    }
}

std::uint8_t function_of(const Call& call) noexcept {
    struct {
        std::uint8_t operator()(const ReadRegisters& r) const { return r.function; }
        std::uint8_t operator()(const WriteRegisters& w) const { return w.function; }
        std::uint8_t operator()(const ReadDeviceId& /*id*/) const { return kEncapsulated; }
        std::uint8_t operator()(const Diagnostic& /*d*/) const { return kDiagnostics; }
    } visitor;
    return std::visit(visitor, call);
}

std::vector<std::uint8_t> exception_pdu(std::uint8_t function, Exception code) {
    return {static_cast<std::uint8_t>(function | 0x80), static_cast<std::uint8_t>(code)};
}

std::vector<std::uint8_t> read_pdu(std::uint8_t function, std::span<const std::uint16_t> values) {
    std::vector<std::uint8_t> out;
    out.reserve(2 + 2 * values.size());
    out.push_back(function);
    out.push_back(static_cast<std::uint8_t>(2 * values.size()));
    for (const auto v : values) {
        push16(out, v);
    }
    return out;
}

std::vector<std::uint8_t> write_pdu(const WriteRegisters& write) {
    std::vector<std::uint8_t> out{write.function};
    push16(out, write.start);
    push16(out, write.function == kWriteSingle ? write.values.at(0) : static_cast<std::uint16_t>(write.values.size()));
    return out;
}

std::vector<std::uint8_t> device_id_pdu(const ReadDeviceId& request,
                                        const std::vector<std::pair<std::uint8_t, std::string>>& objects) {
    std::vector<std::uint8_t> out{kEncapsulated, kMeiDeviceId, request.code, 0x81, 0x00, 0x00, 0x00};
    std::uint8_t count = 0;
    std::size_t room = kMaxObjectBytes;
    for (const auto& [id, text] : objects) {
        const bool wanted = request.code == 4 ? id == request.object : id >= request.object;
        if (!wanted) {
            continue;
        }
        const std::size_t length = std::min<std::size_t>(text.size(), 0xFF);
        if (length + 2 > room) {
            break;  // all three basic objects fit: an Altivar's are short
        }
        out.push_back(id);
        out.push_back(static_cast<std::uint8_t>(length));
        out.insert(out.end(), text.begin(), text.begin() + static_cast<std::ptrdiff_t>(length));
        room -= length + 2;
        ++count;
    }
    out[6] = count;
    return out;
}

std::vector<std::uint8_t> diagnostic_pdu(std::uint16_t sub, std::span<const std::uint8_t> data) {
    std::vector<std::uint8_t> out{kDiagnostics};
    push16(out, sub);
    out.insert(out.end(), data.begin(), data.end());
    return out;
}

}  // namespace drivebus::gateway
