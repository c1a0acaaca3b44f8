// SPDX-License-Identifier: Apache-2.0
// Undoes the termios PARMRK marking so that UART parity and framing errors reach the framer.
//
// With INPCK|PARMRK and neither IGNPAR nor ISTRIP, the line discipline delivers a character
// received with a parity or framing error as 0xFF 0x00 c, a break as 0xFF 0x00 0x00, and a
// genuine 0xFF as 0xFF 0xFF. A sequence can be split across reads, so the decoder keeps state.
#pragma once

#include <cstdint>
#include <span>

namespace drivebus::rtu {

struct RxChar {
    std::uint8_t value = 0;
    bool error = false;  // received with a parity or framing error, or a break
    friend bool operator==(const RxChar&, const RxChar&) = default;
};

class ParmrkDecoder {
public:
    // Decodes `raw` into `out` (which must hold raw.size() + 1 characters, the +1 for a
    // pending 0xFF that turns out not to be an escape) and returns how many were written.
    std::size_t decode(std::span<const std::uint8_t> raw, std::span<RxChar> out) noexcept;
    // How many characters decode() would produce from `raw`, without decoding.
    [[nodiscard]] std::size_t count(std::span<const std::uint8_t> raw) const noexcept;
    void reset() noexcept { state_ = State::Plain; }

private:
    enum class State : std::uint8_t { Plain, Escape, Marked };
    // Advances `state` over one byte; returns how many characters that byte completes (0-2).
    static std::size_t step(State& state, std::uint8_t byte) noexcept;
    State state_ = State::Plain;
};

}  // namespace drivebus::rtu
