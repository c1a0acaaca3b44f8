// SPDX-License-Identifier: Apache-2.0
// A client request's outcome in fixed form: what the bus thread hands back to the ipc side for
// every request it took, through the results ring. Pure (types and two conversions).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <type_traits>

#include "master/result.hpp"
#include "master/scheduler.hpp"

namespace drivebus::master {

// Why the bus took a request off the ring and did not send it.
enum class Refusal : std::uint8_t {
    None,
    QueueFull,     // the scheduler's queue was full (the intake's limit should prevent it)
    UnknownDrive,  // no configured drive at the request's address
    // Through an indirect block the drive has not been seen to apply (its set-up failed, or a
    // reset is awaited).
    BlockUnconfirmed,
    BusDown,    // the line is not open, or went down while the request waited
    Withdrawn,  // withdrawn by its client before it reached the wire
    Expired,    // its deadline passed before it reached the wire
    // Not an end: a withdrawal came too late, the request has reached the wire (or finished);
    // its own result comes (or came) apart.
    NotWithdrawn,
};

// A client request's outcome in fixed form.
struct Finished {
    std::uint64_t id = 0;  // the ClientRequest's correlation: the ipc side's id
    Refusal refusal = Refusal::None;
    Outcome outcome = Outcome::Timeout;
    std::uint8_t exception = 0;  // the Modbus exception code, when outcome is Exception
    std::uint8_t attempts = 0;
    rtu::Instant finished{};
    rtu::Duration late_latency{};                    // Late: the latest late reply, from its attempt
    rtu::RegisterValues words;                       // a read's values
    std::array<std::array<char, 64>, 3> identity{};  // FC43/14: vendor, product code, revision
};
static_assert(std::is_trivially_copyable_v<Finished>);
static_assert(std::is_trivially_copyable_v<ClientRequest>);

[[nodiscard]] inline Finished finished(std::uint64_t id, const Result& result) noexcept {
    Finished f;
    f.id = id;
    f.outcome = result.outcome;
    f.attempts = static_cast<std::uint8_t>(std::min(result.attempts, 255U));
    f.finished = result.finished;
    f.late_latency = result.late_latency;
    if (result.unsent) {  // never sent: refused, whatever it would have been
        f.refusal = result.outcome == Outcome::Expired ? Refusal::Expired : Refusal::BusDown;
    }
    if (const auto code = result.exception()) {
        f.exception = static_cast<std::uint8_t>(*code);
    }
    if (!result.response) {
        return f;
    }
    if (const auto* read = std::get_if<rtu::ReadHoldingRegistersResponse>(&*result.response)) {
        f.words = read->values;
    } else if (const auto* ident = std::get_if<rtu::DeviceIdentificationResponse>(&*result.response)) {
        for (const auto& object : ident->objects) {
            if (object.id < f.identity.size()) {
                auto& text = f.identity.at(object.id);
                const auto n = std::min(object.value.size(), text.size() - 1);
                std::copy_n(object.value.begin(), n, text.begin());
            }
        }
    }
    return f;
}

[[nodiscard]] inline Finished refused(std::uint64_t id, Refusal why) noexcept {
    Finished f;
    f.id = id;
    f.refusal = why;
    f.outcome = Outcome::BusDown;
    return f;
}

}  // namespace drivebus::master
