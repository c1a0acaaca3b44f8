// What the master knows about a drive and a bus, handed to whoever publishes it.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

#include "rtu/timing.hpp"

namespace drivebus::master {

enum class Health : std::uint8_t { Unknown, Online, Absent };

struct RegisterValue {
    std::uint16_t value = 0;
    bool valid = false;
    rtu::Instant time{};  // end of the reply it came from
};

struct DriveCounters {
    std::uint64_t requests = 0;    // attempts sent
    std::uint64_t replies = 0;     // valid replies (exceptions included)
    std::uint64_t timeouts = 0;    // attempts without a reply
    std::uint64_t bad_frames = 0;  // replies spoiled (CRC, gap, parity) or malformed
    std::uint64_t retries = 0;
    std::uint64_t absent_transitions = 0;
    std::uint64_t late = 0;        // replies that came after their attempt timed out: discarded
    std::array<std::uint64_t, 12> exceptions{};  // by code (index 0: codes above 11)
};

struct DriveSnapshot {
    std::string bus;
    std::string name;
    std::uint8_t address = 0;
    std::string profile;
    Health health = Health::Unknown;
    std::map<std::uint16_t, RegisterValue> registers;
    DriveCounters counters;
    std::uint64_t sequence = 0;  // increases with every snapshot of this drive
};

struct TimingStats {
    std::uint64_t count = 0;
    rtu::Duration total{};
    rtu::Duration max{};
    void add(rtu::Duration d) noexcept {
        ++count;
        total += d;
        max = std::max(max, d);
    }
    [[nodiscard]] rtu::Duration mean() const noexcept {
        return count == 0 ? rtu::Duration{} : total / static_cast<std::int64_t>(count);
    }
};

struct BusCounters {
    std::uint64_t transmissions = 0;
    std::uint64_t replies = 0;
    std::uint64_t timeouts = 0;
    std::uint64_t crc_errors = 0;
    std::uint64_t gap_errors = 0;
    std::uint64_t parity_errors = 0;
    std::uint64_t overflows = 0;
    std::uint64_t noise = 0;      // frames too short to be anything
    std::uint64_t foreign = 0;    // valid frames that were not the awaited reply
    std::uint64_t malformed = 0;  // from the addressed slave, but not a valid reply
    std::uint64_t echo_mismatches = 0;
    std::uint64_t retries = 0;
    std::uint64_t broadcasts = 0;
    std::uint64_t queue_rejections = 0;
    std::uint64_t line_down = 0;  // times the device went away
    std::uint64_t late_replies = 0;  // replies after their attempt timed out: discarded
    std::uint64_t held_replies = 0;  // replies whose delivery was held back and still completed
    std::array<std::uint64_t, 12> exceptions{};
};

struct BusStatus {
    std::string name;
    bool up = false;
    BusCounters counters;
    TimingStats reply_latency;  // request off the wire to the reply's last character
    TimingStats extra_gap;      // silence left before a request beyond the t3.5 required
    std::uint64_t sequence = 0;
};

}  // namespace drivebus::master
