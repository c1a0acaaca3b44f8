// SPDX-License-Identifier: Apache-2.0
// What the master knows about a drive and a bus, handed to whoever publishes it.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

#include "rtu/timing.hpp"

namespace drivebus::master {

// Unconfigured: it answers, but its set-up (the selectors of its indirect blocks) failed, did
// not read back as written, or its read block returns something else: not polled, values
// invalid, set up again with back-off. AwaitingReset: the same, because drivebusd wrote
// selectors the drive applies only after a reset (ATV21: F870-F879): power-cycle it.
enum class Health : std::uint8_t { Unknown, Online, Absent, Unconfigured, AwaitingReset };

// Why a drive's set-up did not hold, in fixed form (it travels with the drive's snapshot).
struct SetupNote {
    enum class Kind : std::uint8_t {
        None,
        Refused,       // the drive did not take selector `reg` (`wanted`); `exception`, 0 for no valid reply
        ReadBack,      // selector `reg` was written `wanted` and reads `held`
        BlockDiffers,  // slot `slot` of the block at `block` reads `held`; its register `reg` reads `wanted`
        NotApplied,    // selectors written (the first: `reg`) that the drive applies after a reset
        CannotTell,    // a reset is awaited, and the values of the block at `block` cannot yet tell
                       // the new selection from the one before
    };
    Kind kind = Kind::None;
    std::uint16_t reg = 0;
    std::uint16_t wanted = 0;
    std::uint16_t held = 0;
    std::uint16_t block = 0;
    std::uint8_t slot = 0;  // from 1
    std::uint8_t exception = 0;
};

// The drive's own Modbus time-out (its profile's [safety]) as drivebusd found it when the drive
// came online (master/comm_timeout.hpp).
struct CommTimeoutNote {
    enum class State : std::uint8_t {
        Unknown,       // the profile names none, or it has not been read since the drive came online
        Read,          // `raw` is what the drive holds
        Written,       // drivebusd wrote `wanted`, and it reads back
        ReadRefused,   // reading it got exception `exception` (0: no valid reply)
        WriteRefused,  // writing `wanted` got exception `exception` (0: no valid reply); `raw` as read before
        ReadBack,      // written `wanted`, it reads `raw`
    };
    enum class Verdict : std::uint8_t {
        None,     // not known
        Fine,     // on, and longer than `gap`
        Off,      // off: when the line or drivebusd dies, the drive runs on at its last command
        MayFire,  // not longer than `gap` (or nothing bounds the gap): the drive may trip while all is well
    };
    State state = State::Unknown;
    Verdict verdict = Verdict::None;
    std::uint8_t exception = 0;
    bool action_read = false;  // `action` holds the fault behaviour register (ATV21: F603)
    std::uint16_t raw = 0;
    std::uint16_t action = 0;
    std::optional<std::uint16_t> wanted;  // the configured comm_timeout, in raw counts
    std::uint32_t timeout_ms = 0;         // `raw` in milliseconds; 0: off
    std::uint32_t wanted_ms = 0;          // `wanted` in milliseconds; 0: none
    // The longest drivebusd may leave between two requests to the drive; absent: nothing bounds it.
    std::optional<rtu::Duration> gap;
};

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
    std::uint64_t late = 0;                      // replies that came after their attempt timed out: discarded
    std::array<std::uint64_t, 12> exceptions{};  // by code (index 0: codes above 11)
};

// The registers a snapshot carries, as many as the shared-memory snapshot can (the
// configuration check refuses more): a fixed table sorted by address, so that a poll cycle
// copies it without allocating and the copy can cross threads through a ring.
inline constexpr std::size_t kMaxSnapshotRegisters = 128;

struct RegisterEntry {
    std::uint16_t address = 0;
    RegisterValue value;
};

class RegisterTable {
public:
    // The value at `address`, added (in address order) if new. Past the table's capacity the
    // register is not kept: the returned slot is a scratch one, overwritten by the next.
    RegisterValue& operator[](std::uint16_t address) noexcept {
        auto* it = std::lower_bound(begin(), end(), address,
                                    [](const RegisterEntry& e, std::uint16_t a) { return e.address < a; });
        if (it != end() && it->address == address) {
            return it->value;
        }
        if (count_ == entries_.size()) {
            scratch_ = {};
            return scratch_;
        }
        std::move_backward(it, end(), end() + 1);
        ++count_;
        *it = RegisterEntry{address, {}};
        return it->value;
    }
    [[nodiscard]] bool contains(std::uint16_t address) const noexcept {
        return std::ranges::any_of(*this, [&](const RegisterEntry& e) { return e.address == address; });
    }
    [[nodiscard]] const RegisterValue& at(std::uint16_t address) const {
        for (const auto& e : *this) {
            if (e.address == address) {
                return e.value;
            }
        }
        throw std::out_of_range("register not in the snapshot");
    }
    [[nodiscard]] const RegisterEntry* begin() const noexcept { return entries_.data(); }
    [[nodiscard]] const RegisterEntry* end() const noexcept { return entries_.data() + count_; }
    [[nodiscard]] RegisterEntry* begin() noexcept { return entries_.data(); }
    [[nodiscard]] RegisterEntry* end() noexcept { return entries_.data() + count_; }
    [[nodiscard]] std::size_t size() const noexcept { return count_; }
    [[nodiscard]] bool empty() const noexcept { return count_ == 0; }

private:
    std::array<RegisterEntry, kMaxSnapshotRegisters> entries_{};
    std::size_t count_ = 0;
    RegisterValue scratch_;
};

// Fixed-size and trivially copyable: the names point into the configuration, which outlives
// every bus thread and every reader of a snapshot.
struct DriveSnapshot {
    std::string_view bus;
    std::string_view name;
    std::uint8_t address = 0;
    std::string_view profile;
    Health health = Health::Unknown;
    RegisterTable registers;
    DriveCounters counters;
    std::uint64_t sequence = 0;  // the drive's completed poll cycles and absences, as the scheduler counts them
    SetupNote setup;             // Unconfigured, AwaitingReset: why
    CommTimeoutNote comm_timeout;
};
static_assert(std::is_trivially_copyable_v<DriveSnapshot>);

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
    std::uint64_t line_down = 0;     // times the device went away
    std::uint64_t late_replies = 0;  // replies after their attempt timed out: discarded
    std::uint64_t held_replies = 0;  // replies whose delivery was held back and still completed
    std::uint64_t sync_probes = 0;   // requests sent to prove a slave in step (master/reply_ledger.hpp)
    std::uint64_t mute_reopens = 0;  // the port reopened because the open line heard nothing (mute_watch.hpp)
    std::array<std::uint64_t, 12> exceptions{};
};

// Every counter of BusCounters but `exceptions`, in its order (X(name) each): what the ipc side
// copies into shm::BusCounters by name, so that the two structs cannot drift apart unseen.
// clang-format off: one counter a line (the formatter would wrap them differently each run)
#define DRIVEBUS_MASTER_BUS_COUNTERS(X) \
    X(transmissions) \
    X(replies) \
    X(timeouts) \
    X(crc_errors) \
    X(gap_errors) \
    X(parity_errors) \
    X(overflows) \
    X(noise) \
    X(foreign) \
    X(malformed) \
    X(echo_mismatches) \
    X(retries) \
    X(broadcasts) \
    X(queue_rejections) \
    X(line_down) \
    X(late_replies) \
    X(held_replies) \
    X(sync_probes) \
    X(mute_reopens)
// clang-format on
#define DRIVEBUS_MASTER_COUNT_ONE(name) +1
static_assert(sizeof(BusCounters) ==
                  sizeof(std::uint64_t) * (0 DRIVEBUS_MASTER_BUS_COUNTERS(DRIVEBUS_MASTER_COUNT_ONE)) +
                      sizeof(BusCounters::exceptions),
              "DRIVEBUS_MASTER_BUS_COUNTERS must list every field of master::BusCounters but exceptions");
#undef DRIVEBUS_MASTER_COUNT_ONE

struct BusStatus {
    std::string name;
    bool up = false;
    BusCounters counters;
    TimingStats reply_latency;  // request off the wire to the reply's last character
    TimingStats extra_gap;      // silence left before a request beyond the t3.5 required
    std::uint64_t sequence = 0;
};

}  // namespace drivebus::master
