// SPDX-License-Identifier: Apache-2.0
// Fault injection settings and what was injected. Settings are per drive address, with a
// line-wide default that applies to drives without their own.
#pragma once

#include <cstddef>
#include <cstdint>
#include <expected>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "rtu/timing.hpp"
#include "rtu/types.hpp"

namespace drivebus::sim {

struct DriveFaults {
    double crc = 0.0;                       // share of replies sent with a corrupted CRC
    double drop = 0.0;                      // share of requests left unanswered (absent slave)
    rtu::Duration late{0};                  // added to the turnaround before the reply
    std::optional<std::size_t> gap_at;      // a silence before byte k of the reply...
    double gap_chars = 0.0;                 // ...of this many character times
    std::size_t noise = 0;                  // noise bytes sent before the reply...
    double noise_gap_chars = 2.0;           // ...followed by this much silence (character times)
    std::optional<std::uint8_t> exception;  // answer every request with this exception code
    friend bool operator==(const DriveFaults&, const DriveFaults&) = default;
};

struct FaultCounters {
    std::uint64_t requests = 0;  // valid requests addressed to a simulated drive
    std::uint64_t broadcasts = 0;
    std::uint64_t replies = 0;
    std::uint64_t exceptions = 0;  // exception replies, injected or not
    std::uint64_t foreign = 0;     // valid frames for addresses no simulated drive has
    std::uint64_t broken = 0;      // frames discarded by the framer or failing to decode
    // Injected:
    std::uint64_t crc = 0;
    std::uint64_t dropped = 0;
    std::uint64_t late = 0;
    std::uint64_t gap = 0;
    std::uint64_t noise = 0;
    std::uint64_t echoed = 0;  // bytes echoed
    std::uint64_t injected_exceptions = 0;

    [[nodiscard]] std::string to_string() const;  // "requests=12 replies=11 ... crc=1"
};

class FaultTable {
public:
    // Applies "key=value" to the faults of `address` (0: the line-wide default). Keys: crc,
    // drop, late, gap (K:N), noise (N[:GAP]), exception (1-255, or "off"), echo (0/1, always
    // line-wide). Nothing changes when it fails.
    std::expected<void, std::string> apply(rtu::SlaveAddress address, std::string_view assignment);
    // Clears the faults of one address, or all of them (and echo) with nullopt.
    void clear(std::optional<rtu::SlaveAddress> address);

    [[nodiscard]] const DriveFaults& for_drive(rtu::SlaveAddress address) const noexcept;
    [[nodiscard]] bool echo() const noexcept { return echo_; }
    [[nodiscard]] std::string to_string() const;  // one line describing every setting in force

private:
    std::map<rtu::SlaveAddress, DriveFaults> faults_;  // 0 is the line-wide default
    bool echo_ = false;
};

// A duration of a fault or an option: drivebus's one grammar (lib/duration: "1ms", "250us",
// "2s", "1500000ns"), from 0 to 1 hour.
[[nodiscard]] std::expected<rtu::Duration, std::string> option_duration(std::string_view text);

}  // namespace drivebus::sim
