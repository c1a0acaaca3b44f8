// SPDX-License-Identifier: Apache-2.0
// libdrivebus's errors: their kinds in words, Modbus exceptions by name, and a response from
// drivebusd turned into the error it stands for.
#include "bus_impl.hpp"
#include "rtu/types.hpp"

namespace drivebus {

std::string_view exception_name(std::uint8_t code) noexcept {
    return rtu::to_string(static_cast<rtu::ExceptionCode>(code));
}

std::int64_t monotonic_ns(Clock::time_point t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

Error make_error(ErrorKind kind, std::string message) {
    Error e;
    e.kind = kind;
    e.message = std::move(message);
    return e;
}

std::string_view to_string(ErrorKind kind) noexcept {
    switch (kind) {
    case ErrorKind::Exception: return "exception";
    case ErrorKind::Timeout: return "timeout";
    case ErrorKind::LateReply: return "late reply";
    case ErrorKind::BadFrame: return "bad frame";
    case ErrorKind::Rejected: return "rejected";
    case ErrorKind::QueueFull: return "queue full";
    case ErrorKind::BusDown: return "bus down";
    case ErrorKind::NotPermitted: return "not permitted";
    case ErrorKind::NotRunning: return "not running";
    case ErrorKind::NoSuchBus: return "no such bus";
    case ErrorKind::DaemonGone: return "daemon gone";
    case ErrorKind::NoReply: return "no reply";
    case ErrorKind::Withdrawn: return "withdrawn";
    case ErrorKind::OutcomeUnknown: return "outcome unknown";
    case ErrorKind::Expired: return "expired";
    case ErrorKind::InvalidArgument: return "invalid argument";
    case ErrorKind::Unsupported: return "unsupported";
    }
    return "error";
}

std::expected<void, Error> check_response(const std::string& what, const shm::Response& r, const Profile* profile) {
    Error e;
    e.exception = r.exception;
    e.reason = r.reason;
    e.lease_holder = std::string(shm::view(r.lease_holder));
    e.lease_holder_pid = r.lease_holder_pid;
    switch (r.status) {
    case shm::Status::Ok: return {};
    case shm::Status::Exception:
        e.kind = ErrorKind::Exception;
        e.message = what + " answered exception " + std::to_string(r.exception) + " (" +
                    std::string(exception_name(r.exception)) + ")";
        break;
    case shm::Status::Timeout:
        e.kind = ErrorKind::Timeout;
        e.message = what + " did not answer (" + std::to_string(r.attempts) +
                    " attempts): check its address, wiring and line settings";
        break;
    case shm::Status::Late:
        e.kind = ErrorKind::LateReply;
        e.message = what + " answers too late: after about " + std::to_string((r.late_us + 500) / 1000) +
                    " ms, past the response time-out (" + std::to_string(r.attempts) +
                    " attempts): raise the bus's response_timeout above that";
        break;
    case shm::Status::BadFrame:
        e.kind = ErrorKind::BadFrame;
        e.message = what + ": the reply was spoiled (CRC, framing, parity or echo): check wiring and termination";
        break;
    case shm::Status::Rejected:
        e.kind = ErrorKind::Rejected;
        e.message = "drivebusd rejected the request to " + what + ": " + rejection_text(r, profile);
        break;
    case shm::Status::QueueFull:
        e.kind = ErrorKind::QueueFull;
        e.message = "the bus's request queue is full; try again shortly";
        break;
    case shm::Status::BusDown:
        e.kind = ErrorKind::BusDown;
        e.message = "the bus is down: its serial device is not open (see journalctl -u drivebusd)";
        break;
    case shm::Status::Withdrawn:
        e.kind = ErrorKind::Withdrawn;
        e.message = "drivebusd did not answer in time; the request to " + what +
                    " was withdrawn before it reached the drive: nothing was sent";
        break;
    case shm::Status::Expired:
        e.kind = ErrorKind::Expired;
        e.message =
            "the request to " + what + " was not on the wire by its deadline: drivebusd dropped it, nothing was sent";
        break;
    case shm::Status::Sent:
        e.kind = ErrorKind::OutcomeUnknown;
        e.message = "drivebusd did not answer in time; the request to " + what +
                    " had already been sent: its outcome is unknown (read the register back)";
        break;
    case shm::Status::NotPermitted:
        e.kind = ErrorKind::NotPermitted;
        if (e.lease_holder.empty()) {
            e.message = "this process does not hold the control lease of " + what +
                        " (it ran out, was taken over or was never taken): write the command or reference to "
                        "take it";
        } else {
            e.message = "another client (" + e.lease_holder + ", pid " + std::to_string(e.lease_holder_pid) +
                        ") holds the control lease of " + what +
                        "; take it over explicitly (drivebusctl write --take-over, WriteOptions::take_over)";
        }
        break;
    }
    return std::unexpected(e);
}

}  // namespace drivebus
