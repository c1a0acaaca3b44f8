// SPDX-License-Identifier: Apache-2.0
// What the gateway does with one request, and how drivebusd's answer becomes a Modbus answer.
// Pure: the snapshot, the time and the peer's rights are arguments.
//
//   read (03/04)  every register polled, valid, younger than max_age and than the last write to
//                 it through the gateway: answered from the snapshot, no line time; the drive
//                 absent: 0x0B at once; else sent to drivebusd
//   write (06/16) refused (0x01) unless the peer may write; else sent, under the peer's lease
//   43/14         sent (Identify); 08 answered from the snapshot (echo, drivebusd's counters)
#pragma once

#include <cstdint>
#include <expected>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "drivebus/client.hpp"
#include "drivebus/shm.hpp"
#include "gateway/pdu.hpp"

namespace drivebus::gateway {

struct Answer {
    std::vector<std::uint8_t> pdu;
    // Set when a write is refused here: why, for the log line that names the peer.
    std::string refused_write;
    bool from_snapshot = false;
};

// To drivebusd: kind, drive, registers and values filled; the caller adds who sends it (lease
// token, client name).
struct Send {
    shm::Request request;
};

using Decision = std::variant<Answer, Send>;

struct Context {
    std::string drive;                             // the drive's name on its bus
    const shm::DriveSnapshot* snapshot = nullptr;  // its latest, if any
    std::int64_t now_ns = 0;                       // CLOCK_MONOTONIC
    std::int64_t max_age_ns = 0;
    bool may_write = false;
    // When the values the gateway last gave of this drive's registers were current
    // (CLOCK_MONOTONIC, by register): a write it carried, acknowledged, or a reply read through
    // drivebusd. A polled value read before is not served, so that a client reads back what it
    // wrote and no value goes back in time.
    const std::map<std::uint16_t, std::int64_t>* written = nullptr;
};

[[nodiscard]] Decision decide(const Call& call, const Context& context);

// The Modbus answer to `call` from drivebusd's response (or the library's error).
[[nodiscard]] std::vector<std::uint8_t> answer(const Call& call, const std::expected<shm::Response, Error>& result);
// The exception a failed response or error maps to; nothing when the response is Ok.
[[nodiscard]] std::optional<Exception> exception_for(const shm::Response& response) noexcept;
[[nodiscard]] Exception exception_for(const Error& error) noexcept;
// One line on why a request failed, for the log ("not permitted: pump-hmi[120] holds the lease").
[[nodiscard]] std::string describe_failure(const std::expected<shm::Response, Error>& result);

}  // namespace drivebus::gateway
