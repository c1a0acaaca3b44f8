// SPDX-License-Identifier: Apache-2.0
#include "rtu/framer.hpp"

#include <algorithm>

#include "rtu/codec.hpp"
#include "rtu/crc.hpp"

namespace drivebus::rtu {

std::string_view to_string(FrameFault fault) noexcept {
    switch (fault) {
    case FrameFault::InterCharacterGap: return "silence longer than 1.5 characters inside a frame";
    case FrameFault::CrcMismatch: return "CRC mismatch";
    case FrameFault::Overflow: return "frame longer than 256 bytes";
    case FrameFault::ParityOrFraming: return "parity or framing error";
    case FrameFault::TooShort: return "frame shorter than 4 bytes";
    }
    return "unknown frame fault";
}

Framer::Framer(CharacterTiming timing, InputMarking marking) noexcept : timing_(timing), marking_(marking) {}

void Framer::feed(std::span<const std::uint8_t> bytes, Instant read_time) noexcept {
    // The characters of one read ended one character time apart, the last at read_time.
    // Count them first (PARMRK escapes make bytes and characters differ) so that each chunk
    // of a large read gets its place in time.
    constexpr std::size_t kChunk = 256;
    std::array<RxChar, kChunk + 1> chars{};
    const std::size_t total = marking_ == InputMarking::Plain ? bytes.size() : parmrk_.count(bytes);
    std::size_t done = 0;
    for (std::size_t offset = 0; offset < bytes.size(); offset += kChunk) {
        const auto part = bytes.subspan(offset, std::min(kChunk, bytes.size() - offset));
        std::size_t n = 0;
        if (marking_ == InputMarking::Plain) {
            for (const std::uint8_t b : part) {
                chars[n++] = RxChar{b, false};
            }
        } else {
            n = parmrk_.decode(part, chars);
        }
        done += n;
        feed_chars(std::span(chars).first(n), read_time - timing_.character * static_cast<std::int64_t>(total - done));
    }
}

void Framer::feed_chars(std::span<const RxChar> chars, Instant read_time) noexcept {
    const auto count = static_cast<std::int64_t>(chars.size());
    for (std::int64_t i = 0; i < count; ++i) {
        receive(chars[static_cast<std::size_t>(i)], read_time - timing_.character * (count - 1 - i));
    }
}

void Framer::receive(RxChar c, Instant t) noexcept {
    ++stats_.characters;
    if (open_) {
        // Timestamps mark the end of a character, so the silence before this one is the
        // distance between ends less one character time.
        const Duration silence = t - last_ - timing_.character;
        if (held_ && reply_open() && t > hold_until()) {
            // Held through a silence, it still runs past the earliest end of a reply on time
            // and the delivery allowance: the silence was on the wire.
            fault_ = FrameFault::InterCharacterGap;
        } else if (silence > timing_.t1_5 && reply_open() && t <= hold_until()) {
            // The reply cannot have ended yet: a silence here is a delivery held back (or a
            // real gap the CRC will judge). Keep the frame open.
            held_ = true;
            resume_at_ = adu_.size();
            resume_first_ = t;
        } else if (silence >= timing_.t3_5) {
            finish_frame();
        } else if (silence > timing_.t1_5) {
            if (expectation_) {
                discard(FrameFault::InterCharacterGap);
            } else if (!fault_) {
                fault_ = FrameFault::InterCharacterGap;
            }
        }
    }
    if (!open_) {
        start_frame(t);
    }
    ++frame_bytes_;
    if (!adu_.push_back(c.value) && !fault_) {
        fault_ = FrameFault::Overflow;
    }
    if (c.error && !fault_) {
        fault_ = FrameFault::ParityOrFraming;
    }
    last_ = t;
    last_activity_ = t;
    note_reply_bound();
    if (expectation_ && !fault_ && !reply_failed_) {
        try_complete_reply();
        note_reply_bound();
    }
}

void Framer::note_reply_bound() noexcept {
    if (!expectation_ || !open_ || adu_.empty() || adu_[0] != expectation_->address) {
        return;
    }
    reply_line_free_ = reply_bound();
}

bool Framer::reply_open() const noexcept {
    return open_ && expectation_ && !fault_ && !reply_failed_ && !adu_.empty() && adu_[0] == expectation_->address;
}

// The reply's length as far as the bytes so far tell: an exception's once the function says
// so, the request's normal reply length otherwise.
std::size_t Framer::bound_length() const noexcept {
    const ReplyLength shape = expected_reply_length(*expectation_);
    const std::size_t normal = shape.length != 0 ? shape.length : ReplyLength::kException;
    if (adu_.size() >= 2) {
        const std::size_t needed = reply_bytes_needed(*expectation_, adu_.bytes());
        if (needed != 0) {
            return needed;
        }
    }
    return normal;
}

Instant Framer::reply_bound() const noexcept {
    const auto characters = static_cast<std::int64_t>(bound_length()) - 1;
    return first_ + timing_.character * characters + timing_.t3_5;
}

void Framer::start_frame(Instant t) noexcept {
    open_ = true;
    adu_.clear();
    frame_bytes_ = 0;
    fault_.reset();
    reply_failed_ = false;
    held_ = false;
    resume_at_ = 0;
    first_ = t;
}

void Framer::try_complete_reply() noexcept {
    const std::size_t needed = reply_bytes_needed(*expectation_, adu_.bytes());
    if (needed == 0) {
        if (!resume_after_silence()) {
            reply_failed_ = true;  // not a reply to our request: frame it by silence
        }
        return;
    }
    if (adu_.size() < needed) {
        return;
    }
    if (adu_.size() == needed && crc_ok(adu_.bytes())) {
        ++stats_.frames;
        if (held_) {
            ++stats_.held_replies;
        }
        push_event(Frame{adu_, first_, last_, held_});
        open_ = false;
        expectation_.reset();
        return;
    }
    if (!resume_after_silence()) {
        reply_failed_ = true;
    }
}

// A held frame that is not the reply: what came before its last silence was noise that began
// with the slave's address; the reply may start after it.
bool Framer::resume_after_silence() noexcept {
    if (!held_ || resume_at_ == 0 || resume_at_ >= adu_.size()) {
        return false;
    }
    ++stats_.gap_errors;
    push_event(DiscardedFrame{FrameFault::InterCharacterGap, resume_at_, first_, resume_first_});
    Adu rest;
    (void)rest.append(adu_.bytes().subspan(resume_at_));
    adu_ = rest;
    frame_bytes_ = adu_.size();
    first_ = resume_first_;
    held_ = false;
    resume_at_ = 0;
    try_complete_reply();
    return true;
}

void Framer::finish_frame() noexcept {
    if (fault_) {
        discard(*fault_);
    } else if (adu_.size() < kMinAduSize) {
        discard(FrameFault::TooShort);
    } else if (!crc_ok(adu_.bytes())) {
        discard(FrameFault::CrcMismatch);
    } else {
        ++stats_.frames;
        push_event(Frame{adu_, first_, last_});
        open_ = false;
        if (expectation_) {
            expectation_.reset();  // something complete arrived instead: the caller decides
        }
    }
}

void Framer::discard(FrameFault fault) noexcept {
    switch (fault) {
    case FrameFault::InterCharacterGap: ++stats_.gap_errors; break;
    case FrameFault::CrcMismatch: ++stats_.crc_errors; break;
    case FrameFault::Overflow: ++stats_.overflows; break;
    case FrameFault::ParityOrFraming: ++stats_.parity_errors; break;
    case FrameFault::TooShort: ++stats_.noise; break;
    }
    push_event(DiscardedFrame{fault, frame_bytes_, first_, last_});
    open_ = false;
}

void Framer::poll(Instant now) noexcept {
    if (open_ && now >= close_at()) {
        finish_frame();
    }
}

Instant Framer::close_at() const noexcept {
    const Instant by_silence = silence_known(last_);
    if (reply_open()) {
        return std::max(by_silence, hold_until());
    }
    return by_silence;
}

// Characters are seen when they end: a character that began just inside t3.5 is still on the
// wire until one character time later. Only then is a silence of t3.5 certain.
Instant Framer::silence_known(Instant last) const noexcept {
    return last + timing_.t3_5 + timing_.character;
}

std::optional<Instant> Framer::deadline() const noexcept {
    if (!open_) {
        return std::nullopt;
    }
    return close_at();
}

void Framer::expect_reply(const RequestAdu& request) noexcept {
    expectation_ = request;
    reply_failed_ = false;
    reply_line_free_.reset();
}

void Framer::reset() noexcept {
    open_ = false;
    adu_.clear();
    frame_bytes_ = 0;
    fault_.reset();
    held_ = false;
    resume_at_ = 0;
    last_activity_.reset();
    reply_line_free_.reset();
    parmrk_.reset();
}

void Framer::push_event(FramerEvent event) noexcept {
    if (queue_count_ == kQueueSize) {
        queue_head_ = (queue_head_ + 1) % kQueueSize;
        --queue_count_;
        ++stats_.events_dropped;
    }
    queue_[(queue_head_ + queue_count_) % kQueueSize] = event;
    ++queue_count_;
}

std::optional<FramerEvent> Framer::next_event() noexcept {
    if (queue_count_ == 0) {
        return std::nullopt;
    }
    FramerEvent event = queue_[queue_head_];
    queue_head_ = (queue_head_ + 1) % kQueueSize;
    --queue_count_;
    return event;
}

}  // namespace drivebus::rtu
