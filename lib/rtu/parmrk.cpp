// SPDX-License-Identifier: Apache-2.0
#include "rtu/parmrk.hpp"

namespace drivebus::rtu {
namespace {
constexpr std::uint8_t kMark = 0xFF;
}

std::size_t ParmrkDecoder::step(State& state, std::uint8_t byte) noexcept {
    switch (state) {
    case State::Plain:
        if (byte == kMark) {
            state = State::Escape;
            return 0;
        }
        return 1;
    case State::Escape:
        state = byte == 0x00 ? State::Marked : State::Plain;
        // 0xFF 0xFF is one data byte; anything but 0x00 after 0xFF is not a sequence the line
        // discipline makes, so both bytes are kept as data.
        return byte == 0x00 ? 0 : (byte == kMark ? 1 : 2);
    case State::Marked: state = State::Plain; return 1;
    }
    return 0;
}

std::size_t ParmrkDecoder::count(std::span<const std::uint8_t> raw) const noexcept {
    State state = state_;
    std::size_t n = 0;
    for (const std::uint8_t byte : raw) {
        n += step(state, byte);
    }
    return n;
}

std::size_t ParmrkDecoder::decode(std::span<const std::uint8_t> raw, std::span<RxChar> out) noexcept {
    std::size_t n = 0;
    auto emit = [&](std::uint8_t value, bool error) {
        if (n < out.size()) {
            out[n++] = RxChar{value, error};
        }
    };
    for (const std::uint8_t byte : raw) {
        const State before = state_;
        const std::size_t produced = step(state_, byte);
        if (produced == 2) {
            emit(kMark, false);
            emit(byte, false);
        } else if (produced == 1) {
            emit(byte, before == State::Marked);
        }
    }
    return n;
}

}  // namespace drivebus::rtu
