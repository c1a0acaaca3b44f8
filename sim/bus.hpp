// SPDX-License-Identifier: Apache-2.0
// The simulated line as the drives see it: frames in, bytes out with the time each must reach
// the master. Pure: the event loop feeds it frames and writes what it plans.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "drive.hpp"
#include "faults.hpp"
#include "rtu/framer.hpp"
#include "rtu/timing.hpp"

namespace drivebus::sim {

// One byte to send, and when it must have arrived at the other end (the end of its
// character on the wire).
struct TxByte {
    rtu::Instant at{};
    std::uint8_t value = 0;
    // The last byte of a reply carries the reply's address and function (for --tx-log).
    bool reply_end = false;
    std::uint8_t address = 0;
    std::uint8_t function = 0;
};
using TxPlan = std::vector<TxByte>;

struct BusOptions {
    rtu::CharacterTiming timing{};
    rtu::Duration turnaround{std::chrono::milliseconds(1)};  // drive processing time after end of frame
    bool pace = true;                                        // space reply characters by the character time
    std::uint32_t seed = 1;                                  // for the shares of faulty replies
};

class Bus {
public:
    explicit Bus(BusOptions options);

    void add(std::unique_ptr<ProfileDrive> drive);
    [[nodiscard]] ProfileDrive* drive(rtu::SlaveAddress address) noexcept;
    [[nodiscard]] std::vector<rtu::SlaveAddress> addresses() const;

    // A complete frame: a drive sees its end t3.5 after its last character, then answers
    // after the turnaround. Returns the reply (and any injected noise) as timed bytes.
    [[nodiscard]] TxPlan on_frame(const rtu::Frame& frame);
    // A frame the framer discarded.
    void on_discarded(const rtu::DiscardedFrame& discarded);
    // Bytes received, each ending at the given time: with echo on, they come straight back,
    // as a 2-wire adapter's receiver hears the master's own transmission.
    [[nodiscard]] TxPlan on_received(std::span<const std::uint8_t> bytes, rtu::Instant last_char_end);
    // Lets every drive's time run to `now`.
    void advance(rtu::Instant now);
    // A request began `at_least` to `at_most` after the last character this line sent (the
    // simulator knows its write only between two clock readings): the master kept about that
    // much silence. `at_least` feeds the distribution; `at_most` below t3.5 is a definite
    // violation. Recorded for the `silences` command.
    void record_silence(rtu::Duration at_least, rtu::Duration at_most);
    // A request followed a reply the simulator failed to pace (a character later than t1.5).
    void record_slip() noexcept { ++slips_; }
    // "count=N short=M min_us=... p50_us=... p99_us=... max_us=..." (short: definitely below t3.5).
    [[nodiscard]] std::string silence_summary() const;

    // A mute line: the adapter on the master's side stays present and delivers nothing (a known
    // ftdi_sio failure), until the master opens the port again (the event loop watches for it).
    void set_muted(bool muted) noexcept { muted_ = muted; }
    [[nodiscard]] bool muted() const noexcept { return muted_; }

    [[nodiscard]] FaultTable& faults() noexcept { return faults_; }
    [[nodiscard]] const FaultCounters& counters() const noexcept { return counters_; }
    [[nodiscard]] const BusOptions& options() const noexcept { return options_; }

private:
    [[nodiscard]] TxPlan plan_reply(const rtu::Adu& reply, const DriveFaults& faults, rtu::Instant start);
    [[nodiscard]] bool chance(double share);

    BusOptions options_;
    std::map<rtu::SlaveAddress, std::unique_ptr<ProfileDrive>> drives_;
    FaultTable faults_;
    FaultCounters counters_;
    // When each drive's last planned reply ends: a drive has one transmitter, so it answers its
    // requests one at a time and in order, however late.
    std::array<rtu::Instant, 256> reply_end_{};
    std::mt19937 rng_;
    std::vector<double> silences_us_;
    std::uint64_t short_silences_ = 0;
    std::uint64_t slips_ = 0;
    bool muted_ = false;
};

}  // namespace drivebus::sim
