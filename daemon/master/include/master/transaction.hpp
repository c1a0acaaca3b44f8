// SPDX-License-Identifier: Apache-2.0
// One request until it has a result: attempts, the response timeout, retries.
//
// A pure state machine, driven by the bus loop's events. The timeout of each attempt runs
// from the moment the request has left the wire (transmitter empty, or its computed wire
// time), not from write(), until the reply begins: the engine does not call on_time() while a
// frame is coming in, so a long reply that began in time gets its own wire time.
//
// Transaction identity: every attempt of one transaction sends the same request, so a reply
// to any of its attempts is a right answer to it. A reply to an earlier transaction is not:
// after an attempt timed out, the transaction waits a late-reply guard before it is sent
// again, and what arrives from the slave in it is discarded and counted as late.
#pragma once

#include <cstdint>
#include <optional>

#include "master/result.hpp"
#include "rtu/framer.hpp"
#include "rtu/pdu.hpp"
#include "rtu/timing.hpp"
#include "rtu/types.hpp"

namespace drivebus::master {

struct TransactionOptions {
    rtu::Duration response_timeout = std::chrono::milliseconds(100);
    unsigned retries = 2;
    rtu::Duration broadcast_turnaround = std::chrono::milliseconds(10);
    // After a time-out, how long a late reply may still come: nothing is sent meanwhile.
    rtu::Duration late_reply_guard{};
    // A compliant slave keeps t3.5 of silence before it answers: a spoiled frame that began
    // sooner than this after the request was written was on its way before it (the rest of a
    // reply the kernel held back) and does not fail the attempt. A good reply is taken whenever
    // it comes: slaves that answer sooner exist (libmodbus's), and a stale reply is kept out by
    // the late-reply guard, not by its timing.
    rtu::Duration earliest_reply{};
};

class Transaction {
public:
    enum class State : std::uint8_t {
        ReadyToSend,    // waiting for the line to be free
        Sending,        // written, not yet off the wire
        AwaitingReply,  // off the wire, response timeout running
        Guard,          // an attempt timed out: a late reply may still come
        BroadcastWait,  // broadcast sent, turnaround running
        Done,
    };
    // What a frame received while awaiting the reply turned out to be.
    enum class Verdict : std::uint8_t {
        Reply,      // the reply: the transaction is done
        Foreign,    // from another slave (a late reply, or noise that framed): ignored
        Malformed,  // from the addressed slave but not a valid reply: the attempt is spoiled
        Late,       // from the addressed slave after its attempt timed out: discarded
        Ignored,    // not awaiting a reply
    };

    Transaction(TransactionOptions options, rtu::RequestAdu request, rtu::Adu adu);

    [[nodiscard]] State state() const noexcept { return state_; }
    [[nodiscard]] const rtu::RequestAdu& request() const noexcept { return request_; }
    [[nodiscard]] const rtu::Adu& adu() const noexcept { return adu_; }
    [[nodiscard]] bool broadcast() const noexcept { return request_.address == rtu::kBroadcastAddress; }
    [[nodiscard]] unsigned attempts() const noexcept { return attempts_; }
    [[nodiscard]] const std::optional<Result>& result() const noexcept { return result_; }

    // The request was written: an attempt begins.
    void written(rtu::Instant now);
    // The request has left the wire.
    void sent(rtu::Instant tx_end);
    // A complete frame while awaiting the reply.
    Verdict on_frame(const rtu::Frame& frame);
    // A frame the framer discarded (CRC, gap, parity) while awaiting the reply, whose first
    // character ended at `began`: the attempt is spoiled. One that began too soon to be the
    // reply is not this attempt's.
    //
    // A spoiled attempt does not end at once: the spoiled frame may have been noise, and the
    // slave's reply still on its way. Retried at once, that reply would be taken for the
    // retry's, and the retry's own reply for the next request's (Modbus RTU has no transaction
    // id). So it waits for a good reply until the response time-out, then keeps the late-reply
    // guard like a timed-out attempt, and fails as BadFrame.
    void on_bad_frame(rtu::Instant now, rtu::Instant began);
    // The echo of the request did not match what was sent.
    void on_echo_mismatch(rtu::Instant now);
    // The line went down: no more attempts.
    void abort(rtu::Instant now);
    // Time passed; handles the response timeout and the broadcast turnaround.
    void on_time(rtu::Instant now);
    // When on_time() must next be called, if a timer runs.
    [[nodiscard]] std::optional<rtu::Instant> deadline() const noexcept;

private:
    void attempt_failed(Outcome why, rtu::Instant now);
    void timed_out(rtu::Instant now);
    [[nodiscard]] Outcome silent_outcome() const noexcept;
    void finish(Outcome outcome, rtu::Instant now);

    TransactionOptions options_;
    rtu::RequestAdu request_;
    rtu::Adu adu_;
    State state_ = State::ReadyToSend;
    unsigned attempts_ = 0;
    rtu::Instant written_at_{};
    rtu::Instant tx_end_{};
    std::optional<rtu::Instant> deadline_;
    std::optional<Result> result_;
    unsigned timeouts_ = 0;
    bool spoiled_ = false;                              // this attempt saw a spoiled frame (see on_bad_frame())
    std::optional<rtu::Instant> first_timeout_tx_end_;  // when the first attempt that timed out left the wire
    unsigned late_ = 0;
    rtu::Duration late_latency_{};
};

}  // namespace drivebus::master
