// SPDX-License-Identifier: Apache-2.0
#include "master/transaction.hpp"

#include <algorithm>

#include "rtu/codec.hpp"

namespace drivebus::master {

std::string_view to_string(Outcome outcome) noexcept {
    switch (outcome) {
    case Outcome::Ok: return "ok";
    case Outcome::Exception: return "exception";
    case Outcome::Timeout: return "timeout";
    case Outcome::BadFrame: return "bad frame";
    case Outcome::EchoMismatch: return "echo mismatch";
    case Outcome::BusDown: return "bus down";
    case Outcome::Late: return "late reply";
    case Outcome::Expired: return "expired";
    }
    return "unknown";
}

Transaction::Transaction(TransactionOptions options, rtu::RequestAdu request, rtu::Adu adu)
    : options_(options), request_(std::move(request)), adu_(adu) {}

void Transaction::written(rtu::Instant now) {
    if (state_ != State::ReadyToSend) {
        return;
    }
    ++attempts_;
    spoiled_ = false;
    written_at_ = now;
    state_ = State::Sending;
    deadline_.reset();
}

void Transaction::sent(rtu::Instant tx_end) {
    if (state_ != State::Sending) {
        return;
    }
    tx_end_ = tx_end;
    if (broadcast()) {
        state_ = State::BroadcastWait;
        deadline_ = tx_end + options_.broadcast_turnaround;
    } else {
        state_ = State::AwaitingReply;
        deadline_ = tx_end + options_.response_timeout;
    }
}

Transaction::Verdict Transaction::on_frame(const rtu::Frame& frame) {
    const bool from_slave = !frame.adu.empty() && frame.adu[0] == request_.address;
    if (state_ == State::Guard) {
        if (!from_slave) {
            return Verdict::Foreign;
        }
        ++late_;
        late_latency_ = std::max(late_latency_, frame.first - tx_end_);
        return Verdict::Late;
    }
    // A reply can beat the computed end of our transmission where nothing paces the line
    // (a pty pair, a USB adapter's buffering): it still answers this request.
    if (state_ != State::AwaitingReply && state_ != State::Sending) {
        return Verdict::Ignored;
    }
    const auto reply = rtu::decode_response(request_, frame.adu.bytes());
    if (!reply) {
        if (frame.adu.empty() || frame.adu[0] != request_.address) {
            return Verdict::Foreign;
        }
        spoiled_ = true;  // perhaps a stale reply of another shape: this one may still come
        return Verdict::Malformed;
    }
    // Made whole in one expression: assigning the response into a fresh Result makes g++ 14
    // see the empty optional's variant as "maybe uninitialized".
    result_.emplace(Result{.response = reply->pdu, .after_timeout = timeouts_ > 0});
    if (first_timeout_tx_end_) {
        result_->possible_latency = frame.first - *first_timeout_tx_end_;
    }
    result_->latency = frame.last - (state_ == State::AwaitingReply ? tx_end_ : written_at_);
    const bool exception = std::holds_alternative<rtu::ExceptionResponse>(reply->pdu);
    finish(exception ? Outcome::Exception : Outcome::Ok, frame.last);
    return Verdict::Reply;
}

void Transaction::on_bad_frame(rtu::Instant /*now*/, rtu::Instant began) {
    if (state_ == State::AwaitingReply && began >= written_at_ + options_.earliest_reply) {
        spoiled_ = true;
    }
}

void Transaction::on_echo_mismatch(rtu::Instant now) {
    if (state_ == State::Sending || state_ == State::AwaitingReply) {
        attempt_failed(Outcome::EchoMismatch, now);
    }
}

void Transaction::abort(rtu::Instant now) {
    if (state_ != State::Done) {
        finish(Outcome::BusDown, now);
    }
}

void Transaction::on_time(rtu::Instant now) {
    if (!deadline_ || now < *deadline_) {
        return;
    }
    if (state_ == State::BroadcastWait) {
        finish(Outcome::Ok, now);
    } else if (state_ == State::AwaitingReply) {
        timed_out(now);
    } else if (state_ == State::Guard) {
        attempt_failed(silent_outcome(), now);
    }
}

void Transaction::timed_out(rtu::Instant now) {
    ++timeouts_;
    if (!first_timeout_tx_end_) {
        first_timeout_tx_end_ = tx_end_;
    }
    if (options_.late_reply_guard.count() > 0) {
        state_ = State::Guard;
        deadline_ = now + options_.late_reply_guard;
        return;
    }
    attempt_failed(silent_outcome(), now);
}

// How an attempt that got no good reply ends: a reply came after its time-out, or a frame was
// spoiled, or nothing came at all.
Outcome Transaction::silent_outcome() const noexcept {
    if (late_ > 0) {
        return Outcome::Late;
    }
    return spoiled_ ? Outcome::BadFrame : Outcome::Timeout;
}

std::optional<rtu::Instant> Transaction::deadline() const noexcept {
    return deadline_;
}

void Transaction::attempt_failed(Outcome why, rtu::Instant now) {
    if (attempts_ <= options_.retries) {
        state_ = State::ReadyToSend;  // sent again once the line has been silent for t3.5
        deadline_.reset();
        return;
    }
    finish(why, now);
}

void Transaction::finish(Outcome outcome, rtu::Instant now) {
    if (!result_) {
        result_ = Result{};
    }
    result_->outcome = outcome;
    result_->after_timeout = timeouts_ > 0;
    result_->attempts = attempts_;
    result_->finished = now;
    result_->late_replies = late_;
    result_->late_latency = late_latency_;
    state_ = State::Done;
    deadline_.reset();
}

}  // namespace drivebus::master
