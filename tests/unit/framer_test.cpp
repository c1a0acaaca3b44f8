// SPDX-License-Identifier: Apache-2.0
// Framer tests on synthetic clocks: each character's end time is computed from the line
// format, so gaps are exact fractions of a character time.
#include "rtu/framer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <ostream>
#include <string>
#include <vector>

#include "hex.hpp"
#include "rtu/codec.hpp"

namespace drivebus::rtu {
namespace {

using test::hex;
using test::to_hex;
using namespace std::chrono_literals;

const auto kFrame = hex("01 10 FA 01 00 01 02 17 70 F3 9A");  // Altivar 21 guide, 7.7
const RequestAdu kRequest{1, ReadHoldingRegisters{0xFD00, 1}};
const auto kReply = hex("01 03 02 17 70 B6 50");  // Altivar 21 guide, 7.4

// A synthetic receive line: feeds characters to a framer with exact timestamps.
class Wire {
public:
    Wire(Framer& framer, CharacterTiming timing) : framer_(framer), timing_(timing) {}

    // Sends `bytes` one character per read, `silence` (in character times) before the first.
    void send(const std::vector<std::uint8_t>& bytes, double silence = 0.0) {
        advance(silence);
        for (std::size_t i = 0; i < bytes.size(); ++i) {
            now_ += timing_.character;
            framer_.feed(std::span(bytes).subspan(i, 1), now_);
        }
    }
    // Sends `bytes` with `gap` (in character times) of silence before byte `at`.
    void send_with_gap(const std::vector<std::uint8_t>& bytes, std::size_t at, double gap) {
        const std::vector<std::uint8_t> head(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(at));
        const std::vector<std::uint8_t> tail(bytes.begin() + static_cast<std::ptrdiff_t>(at), bytes.end());
        send(head);
        send(tail, gap);
    }
    // Sends `bytes` back to back, delivered in reads of the given sizes, each read
    // returning when its last character has arrived.
    void send_in_reads(const std::vector<std::uint8_t>& bytes, const std::vector<std::size_t>& reads,
                       double silence = 0.0) {
        advance(silence);
        std::size_t offset = 0;
        for (const std::size_t n : reads) {
            now_ += timing_.character * static_cast<std::int64_t>(n);
            framer_.feed(std::span(bytes).subspan(offset, n), now_);
            offset += n;
        }
        ASSERT_EQ(offset, bytes.size());
    }
    void advance(double chars) {
        now_ += Duration(std::llround(chars * static_cast<double>(timing_.character.count())));
    }
    void advance(Duration d) { now_ += d; }
    // Lets time run to `after` past the last character's end and polls the framer.
    void idle(Duration after) { framer_.poll(now_ + after); }
    void idle_past_t35() { idle(timing_.t3_5 + timing_.character); }
    [[nodiscard]] Instant now() const { return now_; }

private:
    Framer& framer_;
    CharacterTiming timing_;
    Instant now_{std::chrono::seconds(1000)};
};

std::vector<FramerEvent> drain(Framer& framer) {
    std::vector<FramerEvent> events;
    while (auto e = framer.next_event()) {
        events.push_back(std::move(*e));
    }
    return events;
}

std::string describe(const std::vector<FramerEvent>& events) {
    std::string out;
    for (const auto& e : events) {
        if (const auto* f = std::get_if<Frame>(&e)) {
            out += "frame[" + to_hex(f->adu.bytes()) + "] ";
        } else {
            const auto& d = std::get<DiscardedFrame>(e);
            out += "discard(" + std::string(to_string(d.fault)) + ", " + std::to_string(d.bytes) + ") ";
        }
    }
    return out;
}

struct FormatCase {
    LineFormat format;
    const char* name;
    friend void PrintTo(const FormatCase& c, std::ostream* os) { *os << c.name; }
};

class FramerFormats : public ::testing::TestWithParam<FormatCase> {
protected:
    CharacterTiming timing = character_timing(GetParam().format).value();
    bool fixed_silences = GetParam().format.baud > 19200;
};

INSTANTIATE_TEST_SUITE_P(Lines, FramerFormats,
                         ::testing::Values(FormatCase{{9600, 8, Parity::None, 1}, "9600_8N1"},
                                           FormatCase{{9600, 8, Parity::Even, 1}, "9600_8E1"},
                                           FormatCase{{9600, 8, Parity::None, 2}, "9600_8N2"},
                                           FormatCase{{19200, 8, Parity::None, 1}, "19200_8N1"},
                                           FormatCase{{19200, 8, Parity::Even, 1}, "19200_8E1"},
                                           FormatCase{{19200, 8, Parity::None, 2}, "19200_8N2"},
                                           FormatCase{{115200, 8, Parity::None, 1}, "115200_8N1"},
                                           FormatCase{{115200, 8, Parity::Even, 1}, "115200_8E1"},
                                           FormatCase{{115200, 8, Parity::None, 2}, "115200_8N2"}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST_P(FramerFormats, FrameEndsExactlyAtThreeAndAHalfCharacters) {
    Framer framer(timing);
    Wire wire(framer, timing);
    wire.send(kFrame);
    EXPECT_TRUE(framer.frame_open());
    // A character that began just inside t3.5 would end one character later: only then is
    // the silence certain.
    EXPECT_EQ(framer.deadline(), wire.now() + timing.t3_5 + timing.character);
    wire.idle(timing.t3_5 + timing.character - 1ns);
    EXPECT_FALSE(framer.next_event().has_value());
    wire.idle(timing.t3_5 + timing.character);
    const auto events = drain(framer);
    ASSERT_EQ(events.size(), 1U) << describe(events);
    const auto& frame = std::get<Frame>(events[0]);
    EXPECT_EQ(to_hex(frame.adu.bytes()), to_hex(kFrame));
    EXPECT_EQ(frame.last, wire.now());
    EXPECT_EQ(frame.first, wire.now() - timing.character * static_cast<std::int64_t>(kFrame.size() - 1));
    EXPECT_FALSE(framer.frame_open());
    EXPECT_EQ(framer.stats().frames, 1U);
}

// Silence of `gap` character times before the fifth byte, framed by silence (slave side).
TEST_P(FramerFormats, InterCharacterGaps) {
    struct Expect {
        double gap;
        const char* below_19200;  // events with t1.5 = 1.5 c and t3.5 = 3.5 c
    };
    const std::vector<Expect> cases{
        {1.0, "frame[01 10 FA 01 00 01 02 17 70 F3 9A] "},
        {1.4, "frame[01 10 FA 01 00 01 02 17 70 F3 9A] "},
        {1.6, "discard(silence longer than 1.5 characters inside a frame, 11) "},
        {3.4, "discard(silence longer than 1.5 characters inside a frame, 11) "},
        {3.6, "discard(CRC mismatch, 4) discard(CRC mismatch, 7) "},
    };
    for (const auto& c : cases) {
        Framer framer(timing);
        Wire wire(framer, timing);
        wire.send_with_gap(kFrame, 4, c.gap);
        wire.idle_past_t35();
        const std::string events = describe(drain(framer));
        // Above 19200 bit/s t1.5 is 750 us, over 8 characters at 115200: no gap here matters.
        const std::string expected = fixed_silences ? "frame[01 10 FA 01 00 01 02 17 70 F3 9A] " : c.below_19200;
        EXPECT_EQ(events, expected) << "gap " << c.gap << " characters";
    }
}

// Master side: the kernel may hand a reply over with a silence in it that was never on the
// wire. Until the reply's wire bound (its first character + 6 more characters + t3.5 for this
// 7-byte reply) the frame stays open; complete by then with a good CRC, it is the reply,
// marked held. So its silences may add up to t3.5, no more.
TEST_P(FramerFormats, SilencesInsideAnExpectedReplyAreHeldToItsWireBound) {
    for (const Duration gap : {Duration{0}, timing.t1_5 - 1ns, timing.t1_5 + 1ns, timing.t3_5, timing.t3_5 + 1ns}) {
        Framer framer(timing);
        Wire wire(framer, timing);
        framer.expect_reply(kRequest);
        wire.send(std::vector<std::uint8_t>(kReply.begin(), kReply.begin() + 3));
        wire.advance(gap);
        wire.send(std::vector<std::uint8_t>(kReply.begin() + 3, kReply.end()));
        wire.idle_past_t35();
        const auto events = drain(framer);
        if (gap > timing.t3_5) {
            EXPECT_EQ(describe(events), "discard(silence longer than 1.5 characters inside a frame, 7) ");
            EXPECT_EQ(framer.stats().held_replies, 0U);
            continue;
        }
        ASSERT_EQ(describe(events), "frame[01 03 02 17 70 B6 50] ") << "gap " << gap.count() << " ns";
        const bool held = gap > timing.t1_5;
        EXPECT_EQ(std::get<Frame>(events[0]).held, held) << "gap " << gap.count() << " ns";
        EXPECT_EQ(framer.stats().held_replies, held ? 1U : 0U);
    }
}

TEST_P(FramerFormats, AReplyPastItsWireBoundIsCut) {
    Framer framer(timing);
    Wire wire(framer, timing);
    framer.expect_reply(kRequest);
    wire.send(std::vector<std::uint8_t>(kReply.begin(), kReply.begin() + 3));
    const Instant first = wire.now() - timing.character * 2;
    const Instant bound = first + timing.character * 6 + timing.t3_5;
    // Open through the silence, until the bound: a poll at t3.5 does not close it.
    EXPECT_EQ(framer.reply_line_free(), bound);
    EXPECT_EQ(framer.deadline(), std::max(bound, wire.now() + timing.t3_5 + timing.character));
    framer.poll(bound - 1ns);
    EXPECT_TRUE(framer.frame_open());
    framer.poll(bound);
    EXPECT_FALSE(framer.frame_open());
    wire.advance(bound - wire.now() + timing.character);
    wire.send(std::vector<std::uint8_t>(kReply.begin() + 3, kReply.end()));
    wire.idle_past_t35();
    // The rest that came too late cannot be the reply's: it does not begin with the address.
    EXPECT_EQ(describe(drain(framer)), "discard(frame shorter than 4 bytes, 3) discard(CRC mismatch, 4) ");
    EXPECT_EQ(framer.reply_line_free(), bound) << "the bound outlives the frame, until the next request";
}

// With a delivery allowance the reply stays open that much past its bound: a rest that comes
// by then completes it (held); one that comes later is cut as before, at bound + allowance.
TEST_P(FramerFormats, TheDeliveryAllowanceKeepsTheReplyOpenPastItsBound) {
    const Duration allowance = 30ms;
    for (const bool in_time : {true, false}) {
        // The rest (4 bytes) in one read whose last byte ends `late` past the bound.
        const Duration late = in_time ? allowance - timing.character : allowance + timing.character * 4;
        Framer framer(timing);
        framer.set_delivery_allowance(allowance);
        Wire wire(framer, timing);
        framer.expect_reply(kRequest);
        wire.send(std::vector<std::uint8_t>(kReply.begin(), kReply.begin() + 3));
        const Instant first = wire.now() - timing.character * 2;
        const Instant bound = first + timing.character * 6 + timing.t3_5;
        EXPECT_EQ(framer.reply_line_free(), bound) << "the wire bound does not move";
        EXPECT_EQ(framer.deadline(), bound + allowance);
        framer.poll(bound + allowance - 1ns);
        EXPECT_TRUE(framer.frame_open());
        if (!in_time) {
            framer.poll(bound + allowance);
            EXPECT_FALSE(framer.frame_open());
        }
        wire.advance(bound + late - wire.now() - timing.character * 4);
        wire.send_in_reads(std::vector<std::uint8_t>(kReply.begin() + 3, kReply.end()), {4});
        wire.idle_past_t35();
        if (in_time) {
            EXPECT_EQ(describe(drain(framer)), "frame[01 03 02 17 70 B6 50] ");
            EXPECT_EQ(framer.stats().held_replies, 1U);
        } else {
            EXPECT_EQ(describe(drain(framer)), "discard(frame shorter than 4 bytes, 3) discard(CRC mismatch, 4) ");
            EXPECT_EQ(framer.stats().held_replies, 0U);
        }
    }
}

TEST_P(FramerFormats, TheBoundFollowsWhatTheReplyTurnsOutToBe) {
    Framer framer(timing);
    Wire wire(framer, timing);
    framer.expect_reply(kRequest);
    wire.send(hex("01"));
    const Instant first = wire.now();
    EXPECT_EQ(framer.reply_line_free(), first + timing.character * 6 + timing.t3_5) << "normal reply: 7 bytes";
    wire.send(hex("83 02 C0 F1"));  // exception 2 to FC03: 5 bytes
    EXPECT_EQ(framer.reply_line_free(), first + timing.character * 4 + timing.t3_5);
    EXPECT_EQ(describe(drain(framer)), "frame[01 83 02 C0 F1] ");
    framer.expect_reply(kRequest);
    EXPECT_FALSE(framer.reply_line_free().has_value()) << "a new request: no reply begun";
    wire.send(hex("05 03"), 5.0);  // another slave: no bound
    EXPECT_FALSE(framer.reply_line_free().has_value());
}

// Noise that begins with the slave's address, then a silence, then the reply: the noise is
// dropped once it is clear it was not the reply, and the reply is found after it.
TEST_P(FramerFormats, NoiseBeforeTheReplyIsDroppedAfterASilence) {
    for (const auto& noise : {hex("01"), hex("01 03"), hex("55 01")}) {
        Framer framer(timing);
        Wire wire(framer, timing);
        framer.expect_reply(kRequest);
        wire.send(noise);
        wire.advance(timing.t1_5 + timing.character);
        wire.send(kReply);
        wire.idle_past_t35();
        const std::string expected = "discard(silence longer than 1.5 characters inside a frame, " +
                                     std::to_string(noise.size()) + ") frame[01 03 02 17 70 B6 50] ";
        EXPECT_EQ(describe(drain(framer)), expected) << to_hex(noise);
    }
}

TEST_P(FramerFormats, SplitReadsMakeOneFrame) {
    for (const auto& reads :
         std::vector<std::vector<std::size_t>>{{11}, {1, 10}, {3, 4, 4}, {5, 5, 1}, {2, 2, 2, 2, 3}}) {
        Framer framer(timing);
        Wire wire(framer, timing);
        wire.send_in_reads(kFrame, reads, 5.0);
        wire.idle_past_t35();
        const auto events = drain(framer);
        ASSERT_EQ(events.size(), 1U) << describe(events);
        const auto& frame = std::get<Frame>(events[0]);
        EXPECT_EQ(to_hex(frame.adu.bytes()), to_hex(kFrame));
        // Back-dated timestamps reconstruct the wire timing whatever the read sizes.
        EXPECT_EQ(frame.first, wire.now() - timing.character * 10);
        EXPECT_EQ(frame.last, wire.now());
    }
}

TEST_P(FramerFormats, ReplyCompletesAtItsLengthWithoutWaitingForSilence) {
    Framer framer(timing);
    Wire wire(framer, timing);
    framer.expect_reply(kRequest);
    wire.send_in_reads(kReply, {3, 4}, 2.0);
    const auto events = drain(framer);
    ASSERT_EQ(events.size(), 1U) << describe(events);
    EXPECT_EQ(to_hex(std::get<Frame>(events[0]).adu.bytes()), to_hex(kReply));
    EXPECT_FALSE(framer.deadline().has_value());
    // The line is still kept silent from the last byte on.
    EXPECT_EQ(framer.last_activity(), wire.now());
}

TEST_P(FramerFormats, NoiseBeforeAFrame) {
    {  // Noise, t3.5 of silence, then a frame: the noise is its own (discarded) frame.
        Framer framer(timing);
        Wire wire(framer, timing);
        wire.send_in_reads(hex("00 FF FF"), {3});  // 0x00 and 0xFF, as PARMRK delivers them
        wire.advance(timing.t3_5);
        wire.send(kFrame);
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)),
                  "discard(frame shorter than 4 bytes, 2) frame[01 10 FA 01 00 01 02 17 70 F3 9A] ");
        EXPECT_EQ(framer.stats().noise, 1U);
    }
    {  // Noise then a short gap: a slave loses the frame, as the spec says it must.
        Framer framer(timing);
        Wire wire(framer, timing);
        wire.send(hex("00"));
        wire.send(kFrame, 2.0);
        wire.idle_past_t35();
        const auto expected = fixed_silences ? "discard(CRC mismatch, 12) "
                                             : "discard(silence longer than 1.5 characters inside a frame, 12) ";
        EXPECT_EQ(describe(drain(framer)), expected);
    }
    {  // While expecting a reply, noise followed by the reply after a silence > t1.5.
        Framer framer(timing);
        Wire wire(framer, timing);
        framer.expect_reply(kRequest);
        wire.send(hex("00"));
        wire.advance(timing.t1_5 + 1ns);
        wire.send(kReply);
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)),
                  "discard(silence longer than 1.5 characters inside a frame, 1) frame[01 03 02 17 70 B6 50] ");
    }
    {  // Noise glued to the reply cannot be told apart from it: the frame fails its CRC.
        Framer framer(timing);
        Wire wire(framer, timing);
        framer.expect_reply(kRequest);
        wire.send(hex("00"));
        wire.send(kReply);
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)), "discard(CRC mismatch, 8) ");
    }
}

TEST_P(FramerFormats, TwoFramesBackToBack) {
    {  // Separated by exactly t3.5 of silence.
        Framer framer(timing);
        Wire wire(framer, timing);
        wire.send(kFrame);
        wire.advance(timing.t3_5);
        wire.send(kReply);
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)), "frame[01 10 FA 01 00 01 02 17 70 F3 9A] frame[01 03 02 17 70 B6 50] ");
    }
    {  // A reply followed at once by another frame: the reply completes at its length,
       // the rest is framed by silence.
        Framer framer(timing);
        Wire wire(framer, timing);
        framer.expect_reply(kRequest);
        std::vector<std::uint8_t> both = kReply;
        both.insert(both.end(), kFrame.begin(), kFrame.end());
        wire.send_in_reads(both, {both.size()});
        auto events = drain(framer);
        ASSERT_EQ(events.size(), 1U) << describe(events);
        EXPECT_EQ(to_hex(std::get<Frame>(events[0]).adu.bytes()), to_hex(kReply));
        EXPECT_EQ(std::get<Frame>(events[0]).last, wire.now() - timing.character * 11);
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)), "frame[01 10 FA 01 00 01 02 17 70 F3 9A] ");
    }
}

TEST_P(FramerFormats, ParityMarkedByteSpoilsItsFrame) {
    for (const bool expecting : {false, true}) {
        Framer framer(timing, InputMarking::Parmrk);
        Wire wire(framer, timing);
        if (expecting) {
            framer.expect_reply(kRequest);
        }
        // "01 03 02 17 70 B6 50" with 0x17 received with a parity error: FF 00 17.
        wire.send_in_reads(hex("01 03 02 FF 00 17 70 B6 50"), {9}, 4.0);
        EXPECT_TRUE(framer.frame_open());
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)), "discard(parity or framing error, 7) ");
        EXPECT_EQ(framer.stats().parity_errors, 1U);
    }
}

TEST_P(FramerFormats, EscapedDataBytesAreOneCharacterEach) {
    Framer framer(timing, InputMarking::Parmrk);
    Wire wire(framer, timing);
    // "01 06 FF FF 00 00 89 EE" as the line discipline delivers it: each 0xFF doubled.
    wire.send_in_reads(hex("01 06 FF FF FF FF 00 00 89 EE"), {10}, 4.0);
    wire.idle_past_t35();
    const auto events = drain(framer);
    ASSERT_EQ(events.size(), 1U) << describe(events);
    const auto& frame = std::get<Frame>(events[0]);
    EXPECT_EQ(to_hex(frame.adu.bytes()), "01 06 FF FF 00 00 89 EE");
    EXPECT_EQ(frame.first, wire.now() - timing.character * 7);  // 8 characters, not 10
}

TEST_P(FramerFormats, OverflowPast256Bytes) {
    Framer framer(timing);
    Wire wire(framer, timing);
    const std::vector<std::uint8_t> flood(300, 0x55);
    wire.send_in_reads(flood, {100, 100, 100});
    wire.idle_past_t35();
    EXPECT_EQ(describe(drain(framer)), "discard(frame longer than 256 bytes, 300) ");
    EXPECT_EQ(framer.stats().overflows, 1U);
    EXPECT_EQ(framer.stats().characters, 300U);
}

TEST(Framer, LargeEscapedReadKeepsCharacterTimes) {
    // 300 raw bytes that are 150 escaped 0xFF characters: decoded in chunks, timed as 150.
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing, InputMarking::Parmrk);
    const std::vector<std::uint8_t> raw(300, 0xFF);
    const Instant read_time{std::chrono::seconds(5)};
    framer.feed(raw, read_time);
    framer.poll(read_time + timing.t3_5 + timing.character);
    const auto events = drain(framer);
    ASSERT_EQ(events.size(), 1U);
    const auto& discarded = std::get<DiscardedFrame>(events[0]);
    EXPECT_EQ(discarded.fault, FrameFault::CrcMismatch);
    EXPECT_EQ(discarded.bytes, 150U);
    EXPECT_EQ(discarded.first, read_time - timing.character * 149);
    EXPECT_EQ(discarded.last, read_time);
}

TEST(Framer, FixedSilencesAbove19200AreMeasuredInTime) {
    const auto timing = character_timing({115200, 8, Parity::Even, 1}).value();
    const std::vector<std::pair<Duration, const char*>> cases{
        {700us, "frame[01 10 FA 01 00 01 02 17 70 F3 9A] "},
        {800us, "discard(silence longer than 1.5 characters inside a frame, 11) "},
        {1700us, "discard(silence longer than 1.5 characters inside a frame, 11) "},
        {1750us, "discard(CRC mismatch, 4) discard(CRC mismatch, 7) "},
    };
    for (const auto& [gap, expected] : cases) {
        Framer framer(timing);
        Wire wire(framer, timing);
        wire.send(std::vector<std::uint8_t>(kFrame.begin(), kFrame.begin() + 4));
        wire.advance(gap);
        wire.send(std::vector<std::uint8_t>(kFrame.begin() + 4, kFrame.end()));
        wire.idle_past_t35();
        EXPECT_EQ(describe(drain(framer)), expected) << gap.count() << " ns";
    }
}

TEST(Framer, PlainInputTakesBytesAsTheyAre) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing, InputMarking::Plain);
    Wire wire(framer, timing);
    wire.send_in_reads(hex("01 06 FF FF 00 00 89 EE"), {8});
    wire.idle_past_t35();
    EXPECT_EQ(describe(drain(framer)), "frame[01 06 FF FF 00 00 89 EE] ");
}

TEST(Framer, ReplyFromAnotherSlaveIsFramedBySilence) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing);
    Wire wire(framer, timing);
    framer.expect_reply(kRequest);
    const auto other = hex("02 03 02 17 70 B6 14");
    Adu other_adu;
    other_adu.append(std::span(other).first(5));
    other_adu.append_crc();
    const std::vector<std::uint8_t> bytes(other_adu.bytes().begin(), other_adu.bytes().end());
    wire.send(bytes);
    EXPECT_FALSE(framer.next_event().has_value());  // not complete at 7 bytes: not ours
    wire.idle_past_t35();
    const auto events = drain(framer);
    ASSERT_EQ(events.size(), 1U);
    const auto& frame = std::get<Frame>(events[0]);
    EXPECT_EQ(decode_response(kRequest, frame.adu.bytes()).error(), DecodeError::UnexpectedSlave);
}

TEST(Framer, BadCrcAtTheExpectedLengthWaitsForSilence) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing);
    Wire wire(framer, timing);
    framer.expect_reply(kRequest);
    wire.send(hex("01 03 02 17 70 B6 51"));
    EXPECT_FALSE(framer.next_event().has_value());
    EXPECT_TRUE(framer.frame_open());
    wire.idle_past_t35();
    EXPECT_EQ(describe(drain(framer)), "discard(CRC mismatch, 7) ");
    EXPECT_EQ(framer.stats().crc_errors, 1U);
}

TEST(Framer, ExceptionReplyCompletesAtFiveBytes) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing);
    Wire wire(framer, timing);
    const RequestAdu request{1, ReadHoldingRegisters{0xFD00, 2}};
    framer.expect_reply(request);
    wire.send(hex("01 83 03 01 31"));
    EXPECT_EQ(describe(drain(framer)), "frame[01 83 03 01 31] ");
}

TEST(Framer, EventsBeyondTheQueueAreCounted) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing);
    Wire wire(framer, timing);
    for (int i = 0; i < 10; ++i) {
        wire.send(hex("00"), 4.0);
    }
    wire.idle_past_t35();
    EXPECT_EQ(drain(framer).size(), 8U);
    EXPECT_EQ(framer.stats().events_dropped, 2U);
    EXPECT_EQ(framer.stats().noise, 10U);
}

TEST(Framer, ResetDropsAnOpenFrame) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(timing);
    Wire wire(framer, timing);
    wire.send(hex("01 03"));
    framer.reset();
    EXPECT_FALSE(framer.frame_open());
    EXPECT_FALSE(framer.last_activity().has_value());
    wire.send(kReply, 0.0);
    wire.idle_past_t35();
    EXPECT_EQ(describe(drain(framer)), "frame[01 03 02 17 70 B6 50] ");
}

}  // namespace
}  // namespace drivebus::rtu
