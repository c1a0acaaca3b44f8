// SPDX-License-Identifier: Apache-2.0
// What a Modbus transaction came to, as the master reports it to the scheduler and clients.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "rtu/pdu.hpp"
#include "rtu/timing.hpp"

namespace drivebus::master {

enum class Outcome : std::uint8_t {
    Ok,            // a valid reply (for a broadcast: sent and the turnaround waited)
    Exception,     // the slave answered with an exception
    Timeout,       // no reply on any attempt
    BadFrame,      // the last attempt got a reply with a bad CRC, a gap or a parity error
    EchoMismatch,  // the last attempt's echo differed from what was sent: a collision
    BusDown,       // the line is not open
    Late,          // every attempt timed out, and the slave's replies came after it
    Expired,       // a client request whose deadline passed before it could be sent: never sent
};

[[nodiscard]] std::string_view to_string(Outcome outcome) noexcept;

struct Result {
    Outcome outcome = Outcome::Timeout;
    std::optional<rtu::Response> response;  // Ok (not for broadcasts) and Exception
    unsigned attempts = 0;
    rtu::Duration latency{};  // from the request leaving the wire to the reply's last character
    rtu::Instant finished{};
    // An attempt timed out before the transaction ended, however it ended: its reply may still
    // come (or be the reply taken).
    bool after_timeout = false;
    unsigned late_replies = 0;     // replies discarded because they came after the time-out
    rtu::Duration late_latency{};  // the latest of them, from its attempt leaving the wire
    // For a reply after a time-out: how late it would be as the reply to the first attempt
    // that timed out (the same request, so the same bytes: it may well be that one's).
    rtu::Duration possible_latency{};
    // Never reached the wire (expired, or the line went down while it waited).
    bool unsent = false;

    [[nodiscard]] std::optional<rtu::ExceptionCode> exception() const noexcept {
        if (response) {
            if (const auto* e = std::get_if<rtu::ExceptionResponse>(&*response)) {
                return e->code;
            }
        }
        return std::nullopt;
    }
};

}  // namespace drivebus::master
