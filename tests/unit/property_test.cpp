// SPDX-License-Identifier: Apache-2.0
// Property tests: arbitrary input never crashes or reads out of bounds (run under ASan+UBSan
// too), and whatever decodes re-encodes to exactly the same bytes.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "hex.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"
#include "rtu/framer.hpp"

namespace drivebus::rtu {
namespace {

using test::to_hex;

constexpr int kIterations = 200'000;

// Frames biased towards the interesting: a known function code, plausible lengths and,
// most of the time, a valid CRC so that decoding goes past the CRC check.
class FrameGenerator {
public:
    explicit FrameGenerator(std::uint32_t seed) : rng_(seed) {}

    std::vector<std::uint8_t> next() {
        static constexpr std::array<std::uint8_t, 8> kFunctions{0x03, 0x06, 0x10, 0x2B, 0x83, 0x86, 0x90, 0xAB};
        const std::size_t length = pick(0, 20) == 0 ? pick(0, 300) : pick(2, 40);
        std::vector<std::uint8_t> frame(length);
        for (auto& b : frame) {
            b = static_cast<std::uint8_t>(pick(0, 255));
        }
        if (length > 1 && pick(0, 9) != 0) {
            frame[1] = kFunctions[pick(0, kFunctions.size() - 1)];
        }
        if (length > 2 && frame[1] == 0x2B && pick(0, 3) != 0) {
            frame[2] = kMeiReadDeviceIdentification;
        }
        if (length > 2 && pick(0, 9) != 0) {
            // Make the CRC right.
            const std::uint16_t crc = crc16(std::span(frame).first(length - 2));
            frame[length - 2] = static_cast<std::uint8_t>(crc & 0xFFU);
            frame[length - 1] = static_cast<std::uint8_t>(crc >> 8U);
        }
        return frame;
    }

    RequestAdu request() {
        const auto address = static_cast<SlaveAddress>(pick(0, 255));
        const auto start = static_cast<std::uint16_t>(pick(0, 0xFFFF));
        switch (pick(0, 3)) {
        case 0: return {address, ReadHoldingRegisters{start, static_cast<std::uint16_t>(pick(0, 130))}};
        case 1: return {address, WriteSingleRegister{start, static_cast<std::uint16_t>(pick(0, 0xFFFF))}};
        case 2: {
            RegisterValues values;
            for (std::size_t i = pick(0, 125); i > 0; --i) {
                values.push_back(static_cast<std::uint16_t>(pick(0, 0xFFFF)));
            }
            return {address, WriteMultipleRegisters{start, values}};
        }
        default:
            return {address, ReadDeviceIdentification{static_cast<DeviceIdCode>(pick(0, 5)),
                                                      static_cast<std::uint8_t>(pick(0, 255))}};
        }
    }

    std::size_t pick(std::size_t lo, std::size_t hi) {
        return std::uniform_int_distribution<std::size_t>(lo, hi)(rng_);
    }

private:
    std::mt19937 rng_;
};

TEST(Property, DecodedRequestsReencodeToTheSameBytes) {
    FrameGenerator gen(20261122);
    int decoded = 0;
    for (int i = 0; i < kIterations; ++i) {
        const auto frame = gen.next();
        const auto request = decode_request(frame);
        if (!request) {
            continue;
        }
        ++decoded;
        // The decoder is strict about lengths, so a decoded request is the whole frame.
        if (validate_request(*request).has_value()) {
            const auto again = encode_request(*request);
            ASSERT_TRUE(again.has_value());
            ASSERT_EQ(to_hex(again->bytes()), to_hex(frame));
        }
    }
    EXPECT_GT(decoded, 100);  // the generator does reach the decoders' inner paths
}

TEST(Property, DecodedRepliesReencodeToTheSameBytes) {
    FrameGenerator gen(4711);
    int decoded = 0;
    for (int i = 0; i < kIterations; ++i) {
        auto frame = gen.next();
        const RequestAdu request = gen.request();
        if (!frame.empty() && gen.pick(0, 1) == 0) {
            frame[0] = request.address;  // reach past the address check
            if (frame.size() > 2) {
                const std::uint16_t crc = crc16(std::span(frame).first(frame.size() - 2));
                frame[frame.size() - 2] = static_cast<std::uint8_t>(crc & 0xFFU);
                frame[frame.size() - 1] = static_cast<std::uint8_t>(crc >> 8U);
            }
        }
        const std::size_t needed = reply_bytes_needed(request, frame);
        ASSERT_LE(needed, kMaxAduSize);
        const auto reply = decode_response(request, frame);
        if (!reply) {
            continue;
        }
        ++decoded;
        ASSERT_EQ(reply->address, request.address);
        // A reply that decodes has exactly the length the master would have waited for.
        ASSERT_EQ(needed, frame.size());
        const auto again = encode_response(*reply);
        if (again.has_value()) {
            ASSERT_EQ(to_hex(again->bytes()), to_hex(frame));
        } else {
            // Only an exception code 0 decodes without being something a slave may send.
            ASSERT_EQ(again.error(), ValidationError::InvalidExceptionCode);
        }
    }
    EXPECT_GT(decoded, 100);
}

TEST(Property, EncodedRequestsDecodeBack) {
    FrameGenerator gen(99);
    for (int i = 0; i < kIterations / 4; ++i) {
        const RequestAdu request = gen.request();
        const auto adu = encode_request(request);
        if (!adu) {
            continue;
        }
        ASSERT_LE(adu->size(), kMaxAduSize);
        const auto decoded = decode_request(adu->bytes());
        ASSERT_TRUE(decoded.has_value()) << to_string(decoded.error());
        ASSERT_EQ(*decoded, request);
    }
}

TEST(Property, FramerConservesEveryCharacter) {
    const auto timing = character_timing({19200, 8, Parity::Even, 1}).value();
    std::mt19937 rng(7);
    auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    for (int run = 0; run < 200; ++run) {
        Framer framer(timing, pick(0, 1) == 0 ? InputMarking::Plain : InputMarking::Parmrk);
        if (pick(0, 1) == 0) {
            framer.expect_reply({1, ReadHoldingRegisters{0, static_cast<std::uint16_t>(pick(1, 4))}});
        }
        Instant now{std::chrono::seconds(1)};
        std::uint64_t framed = 0;
        Instant previous_last{};
        auto take = [&] {
            while (auto event = framer.next_event()) {
                if (const auto* frame = std::get_if<Frame>(&*event)) {
                    ASSERT_GE(frame->adu.size(), kMinAduSize);
                    ASSERT_TRUE(crc_ok(frame->adu.bytes()));
                    ASSERT_LE(frame->first, frame->last);
                    ASSERT_GE(frame->first, previous_last);
                    previous_last = frame->last;
                    framed += frame->adu.size();
                } else {
                    const auto& d = std::get<DiscardedFrame>(*event);
                    ASSERT_LE(d.first, d.last);
                    framed += d.bytes;
                }
            }
        };
        for (int read = 0; read < 200; ++read) {
            std::vector<std::uint8_t> bytes(static_cast<std::size_t>(pick(0, 12)));
            for (auto& b : bytes) {
                b = static_cast<std::uint8_t>(pick(0, 3) == 0 ? 0xFF : pick(0, 255));
            }
            now +=
                timing.character * static_cast<std::int64_t>(bytes.size()) + std::chrono::microseconds(pick(0, 4000));
            framer.feed(bytes, now);
            take();
            if (pick(0, 4) == 0) {
                framer.poll(now + timing.t3_5 + timing.character);
                take();
            }
        }
        framer.poll(now + timing.t3_5 + timing.character);
        take();
        // An expected reply that has begun stays open to its wire bound: the framer says when.
        if (const auto deadline = framer.deadline()) {
            framer.poll(*deadline);
            take();
        }
        ASSERT_FALSE(framer.frame_open());
        // Every character received ends up in exactly one frame or discarded frame.
        ASSERT_EQ(framed, framer.stats().characters);
        ASSERT_EQ(framer.stats().events_dropped, 0U);
    }
}

}  // namespace
}  // namespace drivebus::rtu
