// SPDX-License-Identifier: Apache-2.0
// The master side of one bus as a pure machine: bytes and times in, requests to write and
// results out. It owns the framer, the echo filter, the transaction in flight and the
// scheduler, and keeps the line rules: one transaction at a time; a request never starts
// less than t3.5 after the last activity on the line (a received character or the end of our
// own transmission), nor before a reply that has begun can have ended (its wire bound, see
// rtu::Framer), nor while received bytes wait to be read; and after a transaction whose
// attempts timed out, not before that drive's late replies, as far as they have shown
// themselves, have had time to come (they are discarded and counted as late).
//
// The bus loop (OS side) feeds it what the port reads, tells it when a request was written
// and when it left the wire, and wakes it at next_wakeup().
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "master/bus_plan.hpp"
#include "master/echo_filter.hpp"
#include "master/reply_ledger.hpp"
#include "master/scheduler.hpp"
#include "master/snapshot.hpp"
#include "master/transaction.hpp"
#include "rtu/framer.hpp"

namespace drivebus::master {

struct EngineCallbacks {
    std::function<void(const DriveSnapshot&)> snapshot;                           // a drive's poll cycle completed
    std::function<void(std::uint64_t correlation, const Result&)> client_result;  // a client request finished
};

class BusEngine {
public:
    BusEngine(const BusPlan& bus, rtu::CharacterTiming timing, EngineCallbacks callbacks, rtu::Instant now);

    // ---- the line ----
    void line_up(rtu::Instant now);
    void line_down(rtu::Instant now);
    [[nodiscard]] bool up() const noexcept { return up_; }
    // drivebusd stops: the clients' waiting requests are answered bus down, and only the lease
    // fallbacks are sent from now on (Scheduler::wind_down()).
    void wind_down(rtu::Instant now);
    [[nodiscard]] bool winding_down() const noexcept { return scheduler_.winding_down(); }
    // The bus thread reopened the port of a line that heard nothing (master/mute_watch.hpp).
    void count_mute_reopen() noexcept { ++status_.counters.mute_reopens; }

    // What one read() returned (PARMRK-marked), at its read time.
    void on_bytes(std::span<const std::uint8_t> bytes, rtu::Instant read_time);
    // Time passed (a timer fired).
    void on_time(rtu::Instant now);

    // The request to write now, if one is due and the line is free. `input_waiting`: bytes
    // the port has received and not yet handed over (TIOCINQ): the line is not silent.
    [[nodiscard]] std::optional<rtu::Adu> transmission(rtu::Instant now, std::size_t input_waiting = 0);
    // It was written at `now`.
    void written(rtu::Instant now);
    // It left the wire at `tx_end` (transmitter empty, or its computed wire time).
    void transmitted(rtu::Instant tx_end);
    // Whether a request could start now as far as the line goes (up, silent, no frame open).
    [[nodiscard]] bool line_free(rtu::Instant now) const noexcept {
        return up_ && !transmitting_ && !framer_.frame_open() && now >= line_free_at();
    }
    // When the engine wants to be woken next.
    [[nodiscard]] std::optional<rtu::Instant> next_wakeup() const;
    // When transmission() will next have a request for the line, where that is known now: the
    // end of the t3.5 silence, or a poll group's due time if later.
    [[nodiscard]] std::optional<rtu::Instant> next_send_at() const;
    // How many times the request on the line has been written: 1, or more for a retry.
    [[nodiscard]] unsigned attempts() const noexcept { return transaction_ ? transaction_->attempts() : 0; }
    // For a poll cycle's first request: when its period made it due.
    [[nodiscard]] std::optional<rtu::Instant> scheduled() const noexcept {
        return job_ ? job_->scheduled : std::nullopt;
    }

    // ---- clients ----
    // Withdraws the waiting client request `correlation`: false when it has reached the wire
    // (or finished, or is unknown). One held behind a sync probe has not.
    bool withdraw(std::uint64_t correlation);
    std::expected<void, SubmitError> submit(ClientRequest request);

    [[nodiscard]] const BusStatus& status() const noexcept { return status_; }
    [[nodiscard]] const Scheduler& scheduler() const noexcept { return scheduler_; }
    [[nodiscard]] const rtu::Framer& framer() const noexcept { return framer_; }
    [[nodiscard]] EchoSetting echo() const noexcept { return echo_.setting(); }
    // The earliest the next request may start: last line activity + t3.5, a begun reply's wire
    // bound, a late-replying drive's quiet time.
    [[nodiscard]] rtu::Instant line_free_at() const noexcept;
    // How late a drive's replies have been seen to come, plus the guard: after a timed-out
    // attempt to it, the line stays quiet that long. Zero until it has answered late.
    [[nodiscard]] rtu::Duration late_horizon(rtu::SlaveAddress address) const noexcept { return horizon_[address]; }

private:
    void fail_client_jobs(rtu::Instant now);
    void publish(std::size_t drive);
    void take_events(rtu::Instant now);
    void finish_if_done(rtu::Instant now);
    void finish_probe(const Result& probe, rtu::Instant now);
    void expire_clients(rtu::Instant now);
    void report_expired(const Job& job, rtu::Instant now);
    void complete(const Job& job, const Result& result, rtu::Instant now);
    // The job to start now: the one a sync probe went ahead of, or the scheduler's next.
    [[nodiscard]] std::optional<Job> next_job(rtu::Instant now);
    // A sync probe to send ahead of `job`, if its reply could be confused with one still owed.
    [[nodiscard]] std::optional<rtu::Request> probe_for(const Job& job, rtu::Instant now);
    void count_exception(std::optional<rtu::ExceptionCode> code, std::array<std::uint64_t, 12>& table);
    void on_frame(const rtu::Frame& frame);
    void count_late(rtu::SlaveAddress address, rtu::Duration latency);
    [[nodiscard]] bool awaiting_reply() const noexcept;

    rtu::CharacterTiming timing_;
    EngineCallbacks callbacks_;
    rtu::Framer framer_;
    EchoFilter echo_;
    Scheduler scheduler_;
    TransactionOptions options_;
    BusStatus status_;

    bool up_ = false;
    std::optional<Job> job_;
    std::optional<Transaction> transaction_;
    std::optional<rtu::Instant> last_tx_end_;
    bool transmitting_ = false;
    // After a transaction with a timed-out attempt: frames from that slave before this are late.
    std::optional<rtu::Instant> quiet_until_;
    rtu::SlaveAddress quiet_address_ = 0;
    bool quiet_after_transmission_ = false;  // the quiet time starts when the request on the wire has left it
    std::array<rtu::Duration, 256> horizon_{};
    // Which reply can be whose (see master/reply_ledger.hpp).
    ReplyLedger ledger_;
    std::vector<std::vector<rtu::Request>> probes_;  // per drive: its sync probes
    rtu::Duration forget_{};                         // owed replies later than this are forgotten
    std::uint64_t serial_ = 0;                       // of the transaction in flight (0: none yet)
    bool probing_ = false;                           // the transaction in flight is a sync probe
    std::optional<Job> after_probe_;                 // the job the probe went ahead of
};

}  // namespace drivebus::master
