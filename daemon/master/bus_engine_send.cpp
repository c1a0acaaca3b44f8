// SPDX-License-Identifier: Apache-2.0
// The bus engine's sending side: what goes on the line next and when (the job, a sync probe
// ahead of it when its reply could be taken for one still owed, the silences before it), and
// what the engine learns as it leaves. Pure, as the rest of the engine.
#include <algorithm>

#include "master/bus_engine.hpp"
#include "rtu/codec.hpp"

namespace drivebus::master {

std::optional<rtu::Adu> BusEngine::transmission(rtu::Instant now, std::size_t input_waiting) {
    if (!up_ || transmitting_ || framer_.frame_open() || input_waiting > 0 || now < line_free_at()) {
        return std::nullopt;
    }
    if (!transaction_) {
        auto job = next_job(now);
        if (!job) {
            return std::nullopt;
        }
        // By reference: a copy would allocate (its block windows) on every transaction.
        static const rtu::FunctionLimits kSpec = rtu::FunctionLimits::modbus_spec();
        const rtu::FunctionLimits& limits = job->drive == kNoDrive ? kSpec : scheduler_.limits(job->drive);
        auto adu = rtu::encode_request(job->request, limits);
        if (!adu) {
            // Requests are validated before they are queued; this one is dropped, not sent.
            Result rejected;
            rejected.outcome = Outcome::BusDown;
            rejected.finished = now;
            if (job->kind == JobKind::Client && callbacks_.client_result) {
                callbacks_.client_result(job->correlation, rejected);
            }
            return std::nullopt;
        }
        TransactionOptions options = options_;
        if (job->retries) {
            options.retries = *job->retries;
        }
        transaction_.emplace(options, job->request, *adu);
        ++serial_;
        job_ = std::move(*job);
    }
    if (transaction_->state() != Transaction::State::ReadyToSend) {
        return std::nullopt;
    }
    if (transaction_->attempts() > 0) {
        ++status_.counters.retries;
        if (job_->drive != kNoDrive) {
            ++scheduler_.counters(job_->drive).retries;
        }
    }
    // A silence is measured from the last activity on the line; before the first one since the
    // line came up there is none to measure from.
    if (framer_.last_activity() || last_tx_end_) {
        status_.extra_gap.add(now - line_free_at());
    }
    return transaction_->adu();
}

void BusEngine::written(rtu::Instant now) {
    if (!transaction_) {
        return;
    }
    transmitting_ = true;
    transaction_->written(now);
    ++status_.counters.transmissions;
    if (transaction_->broadcast()) {
        ++status_.counters.broadcasts;
    } else {
        ledger_.sent(transaction_->request().address, serial_, transaction_->request().pdu, now);
        framer_.expect_reply(transaction_->request());
        if (job_->drive != kNoDrive) {
            ++scheduler_.counters(job_->drive).requests;
        }
    }
    echo_.expect(transaction_->adu());
}

void BusEngine::transmitted(rtu::Instant tx_end) {
    transmitting_ = false;
    last_tx_end_ = tx_end;
    if (quiet_after_transmission_) {
        quiet_after_transmission_ = false;
        quiet_until_ = tx_end + horizon_[quiet_address_];
    }
    if (transaction_) {
        transaction_->sent(tx_end);
    }
}

std::optional<rtu::Instant> BusEngine::next_send_at() const {
    if (!up_ || transmitting_ || framer_.frame_open()) {
        return std::nullopt;
    }
    if (transaction_) {
        if (transaction_->state() == Transaction::State::ReadyToSend) {
            return line_free_at();
        }
        return std::nullopt;
    }
    if (after_probe_) {
        return line_free_at();
    }
    if (const auto due = scheduler_.next_due()) {
        return std::max(*due, line_free_at());
    }
    return std::nullopt;
}

std::optional<Job> BusEngine::next_job(rtu::Instant now) {
    expire_clients(now);
    if (after_probe_) {
        // Its probe was answered: nothing it could be confused with is owed any more.
        std::optional<Job> job = std::move(after_probe_);
        after_probe_.reset();
        if (!job->deadline || *job->deadline > now) {
            return job;
        }
        report_expired(*job, now);  // the probe took its time
    }
    auto job = scheduler_.next(now, !echo_.decided());
    if (!job) {
        return std::nullopt;
    }
    const auto probe = probe_for(*job, now);
    if (!probe) {
        return job;
    }
    Job sync;
    sync.kind = JobKind::Probe;
    sync.drive = job->drive;
    sync.request = {job->request.address, *probe};
    sync.retries = job->retries;
    after_probe_ = std::move(job);
    probing_ = true;
    ++status_.counters.sync_probes;
    return sync;
}

// Client requests whose deadline has passed are answered now and never sent.
void BusEngine::expire_clients(rtu::Instant now) {
    for (const Job& job : scheduler_.expire(now)) {
        report_expired(job, now);
    }
}

void BusEngine::report_expired(const Job& job, rtu::Instant now) {
    Result expired;
    expired.outcome = Outcome::Expired;
    expired.unsent = true;
    expired.finished = now;
    if (callbacks_.client_result) {
        callbacks_.client_result(job.correlation, expired);
    }
}

std::optional<rtu::Request> BusEngine::probe_for(const Job& job, rtu::Instant now) {
    const rtu::SlaveAddress address = job.request.address;
    if (address == rtu::kBroadcastAddress) {
        return std::nullopt;
    }
    ledger_.forget(address, now, std::max(forget_, 2 * horizon_[address]));
    if (!ledger_.in_doubt(address, job.request.pdu)) {
        return std::nullopt;
    }
    auto probe =
        job.drive == kNoDrive ? std::nullopt : ledger_.choose_probe(address, probes_[job.drive], job.request.pdu);
    if (!probe) {
        // No request of another shape to prove the slave in step: held to the owed attempts,
        // every reply to this job would be taken for an older one's, and every job after it
        // would pay a time-out. The slave is guarded by waiting alone (the quiet time), as
        // docs/drivebusd.md says.
        ledger_.clear(address);
    }
    return probe;
}

std::optional<rtu::Instant> BusEngine::next_wakeup() const {
    std::optional<rtu::Instant> wake;
    auto consider = [&](std::optional<rtu::Instant> t) {
        if (t && (!wake || *t < *wake)) {
            wake = t;
        }
    };
    // While a frame is open, its end (the framer's deadline) comes first; a reply coming in
    // holds the response time-out.
    consider(framer_.deadline());
    if (transaction_ && !(awaiting_reply() && framer_.frame_open())) {
        consider(transaction_->deadline());
    }
    consider(next_send_at());
    // A waiting client request's deadline: answered then, even while the line is busy.
    consider(scheduler_.next_deadline());
    if (after_probe_) {
        consider(after_probe_->deadline);
    }
    return wake;
}

}  // namespace drivebus::master
