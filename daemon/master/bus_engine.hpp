// The master side of one bus as a pure machine: bytes and times in, requests to write and
// results out. It owns the framer, the echo filter, the transaction in flight and the
// scheduler, and keeps the line rules: one transaction at a time, and a request never starts
// less than t3.5 after the last activity on the line (a received character or the end of our
// own transmission).
//
// The bus loop (OS side) feeds it what the port reads, tells it when a request was written
// and when it left the wire, and wakes it at next_wakeup().
#pragma once

#include <functional>
#include <optional>

#include "config/config.hpp"
#include "master/echo_filter.hpp"
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
    BusEngine(const config::BusConfig& bus, rtu::CharacterTiming timing, EngineCallbacks callbacks, rtu::Instant now);

    // ---- the line ----
    void line_up(rtu::Instant now);
    void line_down(rtu::Instant now);
    [[nodiscard]] bool up() const noexcept { return up_; }

    // What one read() returned (PARMRK-marked), at its read time.
    void on_bytes(std::span<const std::uint8_t> bytes, rtu::Instant read_time);
    // Time passed (a timer fired).
    void on_time(rtu::Instant now);

    // The request to write now, if one is due and the line has been silent for t3.5.
    [[nodiscard]] std::optional<rtu::Adu> transmission(rtu::Instant now);
    // It was written at `now`.
    void written(rtu::Instant now);
    // It left the wire at `tx_end` (transmitter empty, or its computed wire time).
    void transmitted(rtu::Instant tx_end);
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
    std::expected<void, SubmitError> submit(ClientRequest request);

    [[nodiscard]] const BusStatus& status() const noexcept { return status_; }
    [[nodiscard]] const Scheduler& scheduler() const noexcept { return scheduler_; }
    [[nodiscard]] const rtu::Framer& framer() const noexcept { return framer_; }
    [[nodiscard]] EchoSetting echo() const noexcept { return echo_.setting(); }
    // The earliest the next request may start: last line activity + t3.5.
    [[nodiscard]] rtu::Instant line_free_at() const noexcept;

private:
    void take_events(rtu::Instant now);
    void finish_if_done(rtu::Instant now);
    void count_exception(std::optional<rtu::ExceptionCode> code, std::array<std::uint64_t, 12>& table);

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
};

}  // namespace drivebus::master
