// SPDX-License-Identifier: Apache-2.0
#include "master/bus_engine.hpp"

#include <algorithm>

#include "rtu/codec.hpp"

namespace drivebus::master {
namespace {

EchoSetting echo_setting(EchoMode mode) {
    switch (mode) {
    case EchoMode::On: return EchoSetting::On;
    case EchoMode::Auto: return EchoSetting::Auto;
    case EchoMode::Off: return EchoSetting::Off;
    }
    return EchoSetting::Off;
}

}  // namespace

BusEngine::BusEngine(const BusPlan& bus, rtu::CharacterTiming timing, EngineCallbacks callbacks, rtu::Instant now)
    : timing_(timing),
      callbacks_(std::move(callbacks)),
      framer_(timing, rtu::InputMarking::Parmrk),
      echo_(echo_setting(bus.echo)),
      scheduler_(bus, now),
      options_{bus.response_timeout, bus.retries, bus.broadcast_turnaround,
               bus.late_reply_guard.value_or(bus.response_timeout), timing.t3_5} {
    status_.name = bus.name;
    framer_.set_delivery_allowance(bus.delivery_allowance);
    for (std::size_t d = 0; d < bus.drives.size(); ++d) {
        probes_.push_back(sync_probes(*bus.drives[d].profile, scheduler_.limits(d)));
    }
    // Ten attempts' worth of waiting, and at least 2 s: a reply later than that is not guarded.
    forget_ =
        std::max<rtu::Duration>(std::chrono::seconds(2), 10 * (options_.response_timeout + options_.late_reply_guard));
}

void BusEngine::line_up(rtu::Instant now) {
    up_ = true;
    status_.up = true;
    framer_.reset();
    last_tx_end_.reset();
    quiet_until_.reset();
    quiet_after_transmission_ = false;
    scheduler_.line_up(now);
    ++status_.sequence;
    // A drive whose set-up or absence the line's loss hid shows it again; one that was online
    // shows it with its next reply, not before.
    for (std::size_t d = 0; d < scheduler_.drive_count(); ++d) {
        if (const auto h = scheduler_.health(d); h != Health::Online && h != Health::Unknown) {
            publish(d);
        }
    }
}

void BusEngine::publish(std::size_t drive) {
    if (callbacks_.snapshot) {
        callbacks_.snapshot(scheduler_.snapshot(drive));
    }
}

void BusEngine::line_down(rtu::Instant now) {
    if (!up_) {
        return;
    }
    up_ = false;
    status_.up = false;
    ++status_.counters.line_down;
    if (transaction_) {
        transaction_->abort(now);
        finish_if_done(now);
    }
    if (after_probe_) {
        Result down;
        down.outcome = Outcome::BusDown;
        down.finished = now;
        down.unsent = true;
        const Job job = std::move(*after_probe_);
        after_probe_.reset();
        complete(job, down, now);
    }
    transmitting_ = false;
    scheduler_.line_down(now);
    // Waiting client requests are answered now, not sent whenever the line comes back.
    fail_client_jobs(now);
    ++status_.sequence;
    // No drive is online on a line that is down.
    for (std::size_t d = 0; d < scheduler_.drive_count(); ++d) {
        publish(d);
    }
}

void BusEngine::wind_down(rtu::Instant now) {
    scheduler_.wind_down();
    fail_client_jobs(now);
}

void BusEngine::fail_client_jobs(rtu::Instant now) {
    for (const Job& job : scheduler_.take_client_jobs()) {
        Result down;
        down.outcome = Outcome::BusDown;
        down.finished = now;
        down.unsent = true;
        if (callbacks_.client_result) {
            callbacks_.client_result(job.correlation, down);
        }
    }
}

rtu::Instant BusEngine::line_free_at() const noexcept {
    rtu::Instant last{};
    if (const auto rx = framer_.last_activity()) {
        last = *rx;
    }
    if (last_tx_end_ && *last_tx_end_ > last) {
        last = *last_tx_end_;
    }
    rtu::Instant free = last + timing_.t3_5;
    if (const auto bound = framer_.reply_line_free(); bound && *bound > free) {
        free = *bound;
    }
    if (quiet_until_ && *quiet_until_ > free) {
        free = *quiet_until_;
    }
    return free;
}

bool BusEngine::awaiting_reply() const noexcept {
    return transaction_ && (transaction_->state() == Transaction::State::AwaitingReply ||
                            transaction_->state() == Transaction::State::Sending);
}

void BusEngine::on_bytes(std::span<const std::uint8_t> bytes, rtu::Instant read_time) {
    if (echo_.status() == EchoFilter::Status::Pending) {
        const std::size_t used = echo_.consume(bytes);
        if (echo_.status() == EchoFilter::Status::Mismatch) {
            ++status_.counters.echo_mismatches;
            if (transaction_) {
                transaction_->on_echo_mismatch(read_time);
            }
        }
        if (echo_.status() == EchoFilter::Status::NoEcho && !echo_.replay().empty()) {
            // Auto mode held these as a possible echo; they were the reply's first bytes.
            rtu::Adu joined;
            if (joined.append(echo_.replay()) && joined.append(bytes)) {
                framer_.feed(joined.bytes(), read_time);
                bytes = {};
            }
        }
        bytes = bytes.subspan(std::min(used, bytes.size()));
    }
    if (!bytes.empty()) {
        framer_.feed(bytes, read_time);
    }
    take_events(read_time);
    finish_if_done(read_time);
}

void BusEngine::on_time(rtu::Instant now) {
    framer_.poll(now);
    take_events(now);
    // The response time-out runs until the reply begins: a frame coming in is judged when the
    // framer closes it, by its completion, its wire bound or a silence.
    if (transaction_ && !(awaiting_reply() && framer_.frame_open())) {
        const auto state = transaction_->state();
        transaction_->on_time(now);
        if (state == Transaction::State::AwaitingReply && transaction_->state() != state) {
            ++status_.counters.timeouts;
            if (job_->drive != kNoDrive) {
                ++scheduler_.counters(job_->drive).timeouts;
            }
        }
    }
    finish_if_done(now);
    expire_clients(now);
}

void BusEngine::take_events(rtu::Instant now) {
    while (auto event = framer_.next_event()) {
        if (const auto* frame = std::get_if<rtu::Frame>(&*event)) {
            on_frame(*frame);
            continue;
        }
        const auto& discarded = std::get<rtu::DiscardedFrame>(*event);
        switch (discarded.fault) {
        case rtu::FrameFault::CrcMismatch: ++status_.counters.crc_errors; break;
        case rtu::FrameFault::InterCharacterGap: ++status_.counters.gap_errors; break;
        case rtu::FrameFault::ParityOrFraming: ++status_.counters.parity_errors; break;
        case rtu::FrameFault::Overflow: ++status_.counters.overflows; break;
        case rtu::FrameFault::TooShort: ++status_.counters.noise; break;
        }
        // A spoiled frame of a reply's size while awaiting the reply was the reply, or ruined
        // it, or was noise before it: the attempt is spoiled (see Transaction::on_bad_frame()).
        // Shorter noise is only counted; the reply may follow it.
        if (transaction_ && discarded.bytes >= rtu::kMinAduSize) {
            transaction_->on_bad_frame(now, discarded.first);
        }
    }
}

void BusEngine::on_frame(const rtu::Frame& frame) {
    const rtu::SlaveAddress from = frame.adu.empty() ? 0 : frame.adu[0];
    if (!frame.adu.empty() &&
        ledger_.received(from, frame.adu.bytes(), transaction_ ? serial_ : 0) == ReplyLedger::Match::Earlier) {
        // It can be the reply to an earlier transaction's attempt, so it is never taken for this
        // one's, whatever its timing.
        count_late(from, frame.first - last_tx_end_.value_or(frame.first));
        return;
    }
    const auto verdict = transaction_ ? transaction_->on_frame(frame) : Transaction::Verdict::Ignored;
    switch (verdict) {
    case Transaction::Verdict::Reply:
        ++status_.counters.replies;
        if (frame.held) {
            ++status_.counters.held_replies;
        }
        return;
    case Transaction::Verdict::Malformed: ++status_.counters.malformed; return;
    case Transaction::Verdict::Late: count_late(from, frame.first - last_tx_end_.value_or(frame.first)); return;
    case Transaction::Verdict::Foreign:
    case Transaction::Verdict::Ignored: break;
    }
    // From a slave whose attempt timed out, before its quiet time ended, or from the slave of
    // the transaction in flight while it does not await a reply: a late reply.
    const bool quiet = quiet_until_ && from == quiet_address_ && frame.first < *quiet_until_;
    const bool current = transaction_ && from == transaction_->request().address && !awaiting_reply();
    if (quiet || current) {
        count_late(from, frame.first - last_tx_end_.value_or(frame.first));
        return;
    }
    ++status_.counters.foreign;
}

// A late reply shows how late this slave answers: the line stays quiet that long (plus the
// guard) after its next timed-out attempt.
void BusEngine::count_late(rtu::SlaveAddress address, rtu::Duration latency) {
    ++status_.counters.late_replies;
    if (const auto drive = scheduler_.drive_at(address)) {
        ++scheduler_.counters(*drive).late;
    }
    horizon_[address] = std::max(horizon_[address], latency + options_.late_reply_guard);
}

void BusEngine::count_exception(std::optional<rtu::ExceptionCode> code, std::array<std::uint64_t, 12>& table) {
    if (code) {
        const auto n = static_cast<std::size_t>(*code);
        ++table[n < table.size() ? n : 0];
    }
}

void BusEngine::finish_if_done(rtu::Instant now) {
    if (!transaction_ || transaction_->state() != Transaction::State::Done) {
        return;
    }
    const Result result = *transaction_->result();
    const Job job = *job_;
    transaction_.reset();
    job_.reset();
    framer_.expect_requests();
    if (probing_) {
        finish_probe(result, now);
        return;
    }
    // A timed-out attempt's reply may still be on its way, and the next request to the slave
    // could look the same: stay quiet for as long as the slave has been seen to answer late.
    const bool timed_out =
        result.after_timeout || result.outcome == Outcome::Timeout || result.outcome == Outcome::Late;
    const rtu::SlaveAddress address = job.request.address;
    if (result.after_timeout && (result.outcome == Outcome::Ok || result.outcome == Outcome::Exception)) {
        // The reply taken may have been a timed-out attempt's, come later than the time-out and
        // the guard: then the slave answers that late, and the last attempt's own reply is
        // still on its way. Remembered as the slave's lateness, so the line stays quiet for it.
        horizon_[address] = std::max(horizon_[address], result.possible_latency + options_.late_reply_guard);
    }
    if (timed_out && horizon_[address].count() > 0) {
        quiet_address_ = address;
        if (transmitting_) {
            // An earlier attempt's reply came while the last one was still going out: the
            // quiet time runs from when that has left the wire.
            quiet_after_transmission_ = true;
        } else if (last_tx_end_) {
            quiet_until_ = *last_tx_end_ + horizon_[address];
        }
    }
    complete(job, result, now);
}

// A sync probe answered: the slave has answered or dropped every request before it, and the
// job it went ahead of is sent next. Not answered: that job ends as the probe did, unsent (the
// slave does not answer, or answers so late that its reply could still be taken for another).
void BusEngine::finish_probe(const Result& probe, rtu::Instant now) {
    probing_ = false;
    if (probe.outcome == Outcome::Ok || probe.outcome == Outcome::Exception || !after_probe_) {
        return;
    }
    const Job job = std::move(*after_probe_);
    after_probe_.reset();
    Result failed = probe;
    failed.response.reset();
    complete(job, failed, now);
}

void BusEngine::complete(const Job& job, const Result& result, rtu::Instant now) {
    if (result.outcome == Outcome::Ok || result.outcome == Outcome::Exception) {
        if (job.request.address != rtu::kBroadcastAddress) {
            status_.reply_latency.add(result.latency);
        }
    }
    count_exception(result.exception(), status_.counters.exceptions);
    if (job.drive != kNoDrive) {
        DriveCounters& c = scheduler_.counters(job.drive);
        if (result.outcome == Outcome::Ok || result.outcome == Outcome::Exception) {
            ++c.replies;
        }
        if (result.outcome == Outcome::BadFrame || result.outcome == Outcome::EchoMismatch) {
            ++c.bad_frames;
        }
        count_exception(result.exception(), c.exceptions);
    }
    if (job.kind == JobKind::Client && callbacks_.client_result) {
        callbacks_.client_result(job.correlation, result);
    }
    if (const auto drive = scheduler_.complete(job, result, now)) {
        publish(*drive);
    }
}

bool BusEngine::withdraw(std::uint64_t correlation) {
    if (after_probe_ && after_probe_->kind == JobKind::Client && after_probe_->correlation == correlation) {
        after_probe_.reset();  // its probe goes on: it proves the drive in step all the same
        return true;
    }
    return scheduler_.withdraw(correlation);
}

std::expected<void, SubmitError> BusEngine::submit(ClientRequest request) {
    auto ok = scheduler_.submit(std::move(request));
    if (!ok && ok.error() == SubmitError::QueueFull) {
        ++status_.counters.queue_rejections;
    }
    return ok;
}

}  // namespace drivebus::master
