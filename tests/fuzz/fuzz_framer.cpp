// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the framer fed arbitrary reads at arbitrary times. Input is a sequence of
// records: [gap in 10 us units][flags][length][bytes...]. Checks that every character ends
// up in exactly one frame or discarded frame, that emitted frames are well formed, and that a
// poll at the framer's deadline closes whatever is open.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "rtu/crc.hpp"
#include "rtu/framer.hpp"

using namespace drivebus::rtu;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) {
        return 0;
    }
    static const CharacterTiming kTiming = character_timing({19200, 8, Parity::Even, 1}).value();
    Framer framer(kTiming, (data[0] & 1U) != 0 ? InputMarking::Parmrk : InputMarking::Plain);
    if ((data[0] & 2U) != 0) {
        framer.expect_reply({1, ReadHoldingRegisters{0, static_cast<std::uint16_t>(1U + (data[0] >> 2U) % 8U)}});
    }
    std::uint64_t accounted = 0;
    auto take = [&] {
        while (auto event = framer.next_event()) {
            if (const auto* frame = std::get_if<Frame>(&*event)) {
                if (frame->adu.size() < kMinAduSize || !crc_ok(frame->adu.bytes()) || frame->first > frame->last) {
                    std::abort();
                }
                accounted += frame->adu.size();
            } else {
                accounted += std::get<DiscardedFrame>(*event).bytes;
            }
        }
    };
    Instant now{std::chrono::seconds(1)};
    std::size_t pos = 1;
    while (pos + 3 <= size) {
        const std::uint8_t gap = data[pos];
        const std::uint8_t flags = data[pos + 1];
        const std::size_t length = std::min<std::size_t>(data[pos + 2], size - pos - 3);
        pos += 3;
        now += std::chrono::microseconds(10 * gap) + kTiming.character * static_cast<std::int64_t>(length);
        framer.feed({data + pos, length}, now);
        pos += length;
        take();
        if ((flags & 1U) != 0) {
            framer.poll(now + kTiming.t3_5 + kTiming.character);
            take();
        }
    }
    framer.poll(now + kTiming.t3_5 + kTiming.character);
    take();
    // An expected reply that has begun stays open to its wire bound: the framer says when.
    if (const auto deadline = framer.deadline()) {
        framer.poll(*deadline);
        take();
    }
    if (framer.frame_open() || accounted != framer.stats().characters) {
        std::abort();
    }
    return 0;
}
