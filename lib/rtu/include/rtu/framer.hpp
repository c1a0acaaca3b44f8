// SPDX-License-Identifier: Apache-2.0
// Turns timestamped received bytes into Modbus RTU frames, by the 1.5 / 3.5 character rules.
//
// Pure: it never reads, sleeps or asks the time. The caller feeds what one read() returned
// with the CLOCK_MONOTONIC time the read returned; the k characters of one read are taken to
// have ended one character time apart, the last one at the read time. The caller also calls
// poll() when deadline() passes, so that a silence can end a frame.
//
// Two ways to end a frame:
//  - by silence (slave side, and the master's fallback): a frame ends when t3.5 passes after
//    its last character (known for certain one character time later, see poll());
//  - by expectation (master side, after expect_reply()): a reply ends as soon as it has the
//    length the request calls for and a good CRC, without waiting for the silence. A reply
//    that does not fit (other slave or function, bad CRC at that length) is framed by silence.
//
// Inside a frame, a silence longer than t1.5 spoils it (spec behaviour, for the slave side).
//
// The master reads the kernel's delivery, not the wire: a worker thread at normal priority
// hands received bytes to the reader, and on a busy machine it holds them back for
// milliseconds, so the master sees silences that were never on the wire. While a reply from
// the addressed slave is open, the wire's physics bound it instead: its last character cannot
// end before its first one's end + (expected length - 1) character times. Until that bound +
// t3.5 (reply_line_free()) the frame stays open through any silence, and if the rest arrives
// and it completes at its expected length with a good CRC it is the reply (Frame::held). The
// master never transmits before that bound either (see BusEngine::line_free_at()).
// On a loaded machine the worker can hold the rest back past the bound as well: a delivery
// allowance (set_delivery_allowance()) keeps the frame open that much longer. The line may be
// free at the bound, but the master does not send while the frame is open, so the allowance
// costs time only when a reply really stops short on the wire.
// A held frame that does not complete as the reply is looked at again from the byte after its
// last silence, so noise before the reply that happened to start with the slave's address
// does not cost the reply.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>

#include "rtu/parmrk.hpp"
#include "rtu/pdu.hpp"
#include "rtu/timing.hpp"
#include "rtu/types.hpp"

namespace drivebus::rtu {

enum class FrameFault : std::uint8_t {
    InterCharacterGap,  // silence > t1.5 inside the frame
    CrcMismatch,
    Overflow,         // more than 256 bytes before a t3.5 silence
    ParityOrFraming,  // a character the UART marked as received with an error
    TooShort,         // fewer than 4 bytes: noise
};
[[nodiscard]] std::string_view to_string(FrameFault fault) noexcept;

struct Frame {
    Adu adu;
    Instant first{};    // end of the first character
    Instant last{};     // end of the last character
    bool held = false;  // a reply that came through a silence longer than t1.5 (late delivery)
};

struct DiscardedFrame {
    FrameFault fault = FrameFault::TooShort;
    std::size_t bytes = 0;
    Instant first{};
    Instant last{};
};

using FramerEvent = std::variant<Frame, DiscardedFrame>;

struct FramerStats {
    std::uint64_t characters = 0;
    std::uint64_t frames = 0;
    std::uint64_t gap_errors = 0;
    std::uint64_t crc_errors = 0;
    std::uint64_t overflows = 0;
    std::uint64_t parity_errors = 0;
    std::uint64_t noise = 0;           // too-short frames
    std::uint64_t events_dropped = 0;  // events not taken before the queue filled
    std::uint64_t held_replies = 0;    // replies completed through a silence (Frame::held)
};

// How the bytes handed to feed() are marked.
enum class InputMarking : std::uint8_t {
    Parmrk,  // termios INPCK|PARMRK: errors arrive as 0xFF 0x00 c, data 0xFF as 0xFF 0xFF
    Plain,   // raw bytes, no error marking
};

class Framer {
public:
    explicit Framer(CharacterTiming timing, InputMarking marking = InputMarking::Parmrk) noexcept;

    // Bytes from one read, returned at `read_time`.
    void feed(std::span<const std::uint8_t> bytes, Instant read_time) noexcept;
    // Already-decoded characters from one read, returned at `read_time`.
    void feed_chars(std::span<const RxChar> chars, Instant read_time) noexcept;
    // Time has reached `now`: ends a frame whose t3.5 silence is certain. Characters are seen
    // when they end, so that is t3.5 plus one character time after the last one (a character
    // that began inside the t3.5 would have ended by then). A character that arrives is judged
    // exactly: a silence >= t3.5 before it ends the frame.
    void poll(Instant now) noexcept;

    // When poll() must next be called: t3.5 + one character after the last character of an
    // open frame, or for an open reply from the addressed slave its wire bound if later.
    [[nodiscard]] std::optional<Instant> deadline() const noexcept;
    // Since expect_reply(): once a reply from the addressed slave has begun, the earliest the
    // line can be free again (its first character's end + (expected length - 1) characters +
    // t3.5), whatever silence was observed.
    [[nodiscard]] std::optional<Instant> reply_line_free() const noexcept { return reply_line_free_; }
    // End of the last character received, if any: the silence clock.
    [[nodiscard]] std::optional<Instant> last_activity() const noexcept { return last_activity_; }
    [[nodiscard]] bool frame_open() const noexcept { return open_; }

    // Master: the next frame is the reply to `request` and may end at its expected length.
    // One expectation ends with one frame; the framer then returns to framing by silence.
    void expect_reply(const RequestAdu& request) noexcept;
    // How long past its wire bound + t3.5 an open reply from the addressed slave may still be
    // completed by bytes the kernel held back (0: none, the default).
    void set_delivery_allowance(Duration allowance) noexcept { allowance_ = allowance; }
    [[nodiscard]] Duration delivery_allowance() const noexcept { return allowance_; }
    // Slave (default): every frame ends by silence.
    void expect_requests() noexcept { expectation_.reset(); }

    // Drops an open frame without an event and forgets the silence clock.
    void reset() noexcept;

    [[nodiscard]] std::optional<FramerEvent> next_event() noexcept;
    [[nodiscard]] const FramerStats& stats() const noexcept { return stats_; }
    [[nodiscard]] const CharacterTiming& timing() const noexcept { return timing_; }

private:
    void receive(RxChar c, Instant t) noexcept;
    [[nodiscard]] Instant silence_known(Instant last) const noexcept;
    void start_frame(Instant t) noexcept;
    void finish_frame() noexcept;
    void try_complete_reply() noexcept;
    [[nodiscard]] bool reply_open() const noexcept;
    [[nodiscard]] std::size_t bound_length() const noexcept;
    [[nodiscard]] Instant reply_bound() const noexcept;
    [[nodiscard]] Instant hold_until() const noexcept { return reply_bound() + allowance_; }
    [[nodiscard]] bool resume_after_silence() noexcept;
    void note_reply_bound() noexcept;
    [[nodiscard]] Instant close_at() const noexcept;
    void discard(FrameFault fault) noexcept;
    void push_event(FramerEvent event) noexcept;

    CharacterTiming timing_;
    InputMarking marking_;
    Duration allowance_{};
    ParmrkDecoder parmrk_;

    Adu adu_;
    std::size_t frame_bytes_ = 0;  // including any past the 256-byte limit
    bool open_ = false;
    std::optional<FrameFault> fault_;
    Instant first_{};
    Instant last_{};
    std::optional<Instant> last_activity_;

    std::optional<RequestAdu> expectation_;
    bool reply_failed_ = false;  // the expected-length check failed for this frame
    bool held_ = false;          // the open reply came through a silence longer than t1.5
    std::size_t resume_at_ = 0;  // the first byte after that silence
    Instant resume_first_{};
    std::optional<Instant> reply_line_free_;

    static constexpr std::size_t kQueueSize = 8;
    std::array<FramerEvent, kQueueSize> queue_{};
    std::size_t queue_head_ = 0;
    std::size_t queue_count_ = 0;

    FramerStats stats_;
};

}  // namespace drivebus::rtu
