// SPDX-License-Identifier: Apache-2.0
#include "gateway/route.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivebus::gateway {
namespace {

// FC08 sub-functions answered from drivebusd's counters of the drive (Modbus Application
// Protocol 6.8): counts as drivebusd has seen them, modulo 2^16.
constexpr std::uint16_t kReturnQueryData = 0x00;
constexpr std::uint16_t kBusMessageCount = 0x0B;
constexpr std::uint16_t kBusCommunicationErrorCount = 0x0C;
constexpr std::uint16_t kBusExceptionErrorCount = 0x0D;
constexpr std::uint16_t kServerMessageCount = 0x0E;
constexpr std::uint16_t kServerNoResponseCount = 0x0F;

Answer refusal(std::uint8_t function, Exception code) {
    return Answer{exception_pdu(function, code), {}, false};
}

shm::Request request_for(const std::string& drive, shm::RequestKind kind) {
    shm::Request r;
    r.kind = kind;
    shm::assign(r.drive, drive);
    return r;
}

bool absent(const Context& c) {
    return c.snapshot != nullptr && c.snapshot->health == shm::DriveHealth::Absent;
}

Decision decide_read(const ReadRegisters& read, const Context& c) {
    if (absent(c)) {
        return refusal(read.function, Exception::GatewayTargetFailed);
    }
    if (c.snapshot != nullptr) {
        std::vector<std::uint16_t> values;
        values.reserve(read.count);
        for (std::uint32_t a = read.start; a < std::uint32_t{read.start} + read.count; ++a) {
            const auto* s = c.snapshot->find(static_cast<std::uint16_t>(a));
            if (s == nullptr || s->valid == 0 || c.now_ns - s->time_ns > c.max_age_ns) {
                break;
            }
            if (c.written != nullptr) {
                const auto w = c.written->find(s->address);
                if (w != c.written->end() && s->time_ns <= w->second) {
                    break;
                }
            }
            values.push_back(s->value);
        }
        if (values.size() == read.count) {
            return Answer{read_pdu(read.function, values), {}, true};
        }
    }
    auto r = request_for(c.drive, shm::RequestKind::Read);
    r.start = read.start;
    r.count = read.count;
    return Send{r};
}

Decision decide_write(const WriteRegisters& write, const Context& c) {
    if (!c.may_write) {
        auto a = refusal(write.function, Exception::IllegalFunction);
        a.refused_write = "writes are not allowed from this address (write_from)";
        return a;
    }
    auto r = request_for(c.drive, shm::RequestKind::Write);
    r.function = write.function;
    r.start = write.start;
    r.count = static_cast<std::uint16_t>(write.values.size());
    std::copy(write.values.begin(), write.values.end(), r.values.begin());
    return Send{r};
}

Decision decide_diagnostic(const Diagnostic& d, const Context& c) {
    if (c.snapshot == nullptr || c.snapshot->health != shm::DriveHealth::Online) {
        return refusal(kDiagnostics, Exception::GatewayTargetFailed);
    }
    if (d.sub == kReturnQueryData) {
        return Answer{diagnostic_pdu(d.sub, d.data), {}, true};
    }
    const auto& n = c.snapshot->counters;
    std::optional<std::uint64_t> count;
    switch (d.sub) {
    case kBusMessageCount: count = n.requests; break;
    case kBusCommunicationErrorCount: count = n.bad_frames; break;
    case kBusExceptionErrorCount: count = n.exceptions; break;
    case kServerMessageCount: count = n.replies; break;
    case kServerNoResponseCount: count = n.timeouts; break;
    default: return refusal(kDiagnostics, Exception::IllegalFunction);
    }
    if (d.data.size() != 2 || d.data[0] != 0 || d.data[1] != 0) {
        return refusal(kDiagnostics, Exception::IllegalDataValue);
    }
    const auto v = static_cast<std::uint16_t>(*count & 0xFFFF);
    const std::vector<std::uint8_t> data{static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v & 0xFF)};
    return Answer{diagnostic_pdu(d.sub, data), {}, true};
}

}  // namespace

Decision decide(const Call& call, const Context& context) {
    if (const auto* read = std::get_if<ReadRegisters>(&call)) {
        return decide_read(*read, context);
    }
    if (const auto* write = std::get_if<WriteRegisters>(&call)) {
        return decide_write(*write, context);
    }
    if (const auto* d = std::get_if<Diagnostic>(&call)) {
        return decide_diagnostic(*d, context);
    }
    if (absent(context)) {
        return refusal(kEncapsulated, Exception::GatewayTargetFailed);
    }
    return Send{request_for(context.drive, shm::RequestKind::Identify)};
}

std::optional<Exception> exception_for(const shm::Response& response) noexcept {
    using S = shm::Status;
    using R = shm::RejectReason;
    switch (response.status) {
    case S::Ok: return std::nullopt;
    case S::Exception: return static_cast<Exception>(response.exception);
    case S::Timeout:
    case S::BadFrame:
    case S::Late:
    case S::Sent: return Exception::GatewayTargetFailed;
    case S::QueueFull:
    case S::NotPermitted:
    case S::Withdrawn:
    case S::Expired: return Exception::ServerDeviceBusy;
    case S::BusDown: return Exception::GatewayPathUnavailable;
    case S::Rejected: break;
    }
    switch (response.reason) {
    case R::UnknownDrive: return Exception::GatewayPathUnavailable;
    case R::UnknownRegister:
    case R::ReadOnly:
    case R::WriteOnly:
    case R::DaemonOwned:
    case R::BlockNotSetUp:
    case R::BlockNotApplied: return Exception::IllegalDataAddress;
    case R::Quantity:
    case R::ValueOutOfRange: return Exception::IllegalDataValue;
    case R::Unsupported: return Exception::IllegalFunction;
    case R::NotPending: return Exception::GatewayTargetFailed;
    case R::None:
    case R::Malformed: break;
    }
    return Exception::ServerDeviceFailure;
}

Exception exception_for(const Error& error) noexcept {
    switch (error.kind) {
    case ErrorKind::Exception: return static_cast<Exception>(error.exception);
    case ErrorKind::QueueFull:
    case ErrorKind::Withdrawn:
    case ErrorKind::Expired: return Exception::ServerDeviceBusy;
    case ErrorKind::Timeout:
    case ErrorKind::BadFrame:
    case ErrorKind::LateReply:
    case ErrorKind::NoReply:
    case ErrorKind::OutcomeUnknown: return Exception::GatewayTargetFailed;
    case ErrorKind::BusDown:
    case ErrorKind::NotRunning:
    case ErrorKind::NoSuchBus:
    case ErrorKind::DaemonGone:
    case ErrorKind::NotPermitted: return Exception::GatewayPathUnavailable;
    case ErrorKind::Rejected:
    case ErrorKind::InvalidArgument:
    case ErrorKind::Unsupported: break;
    }
    return Exception::ServerDeviceFailure;
}

std::vector<std::uint8_t> answer(const Call& call, const std::expected<shm::Response, Error>& result) {
    const std::uint8_t fc = function_of(call);
    if (!result) {
        return exception_pdu(fc, exception_for(result.error()));
    }
    if (const auto code = exception_for(*result)) {
        return exception_pdu(fc, *code);
    }
    if (const auto* read = std::get_if<ReadRegisters>(&call)) {
        if (result->count != read->count) {
            return exception_pdu(fc, Exception::ServerDeviceFailure);
        }
        return read_pdu(fc, std::span(result->values.data(), result->count));
    }
    if (const auto* write = std::get_if<WriteRegisters>(&call)) {
        return write_pdu(*write);
    }
    if (const auto* id = std::get_if<ReadDeviceId>(&call)) {
        std::vector<std::pair<std::uint8_t, std::string>> objects;
        objects.reserve(result->identity.size());
        for (std::size_t i = 0; i < result->identity.size(); ++i) {
            objects.emplace_back(static_cast<std::uint8_t>(i), std::string(shm::view(result->identity[i])));
        }
        return device_id_pdu(*id, objects);
    }
    return exception_pdu(fc, Exception::ServerDeviceFailure);  // FC08 is never sent
}

std::string describe_failure(const std::expected<shm::Response, Error>& result) {
    if (!result) {
        return std::string(to_string(result.error().kind)) + ": " + result.error().message;
    }
    const auto& r = *result;
    switch (r.status) {
    case shm::Status::Exception:
        return fmt::format("the drive answered exception {} ({})", r.exception, exception_name(r.exception));
    case shm::Status::Rejected:
        return fmt::format("rejected by drivebusd: {} (register 0x{:04X})", shm::to_string(r.reason),
                           r.register_address);
    case shm::Status::NotPermitted:
        return fmt::format("not permitted: {}[{}] holds the control lease", shm::view(r.lease_holder),
                           r.lease_holder_pid);
    default: return std::string(shm::to_string(r.status));
    }
}

}  // namespace drivebus::gateway
