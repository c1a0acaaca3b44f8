// SPDX-License-Identifier: Apache-2.0
// A line that is open and hears nothing. A USB adapter can stay present and stop delivering
// what it receives (a known ftdi_sio failure): every request times out, every drive goes
// absent, and nothing short of closing and opening the port again brings it back. When the
// line has heard nothing at all (no reply, no exception, not even a spoiled frame) for `after`
// while requests kept timing out, the watch says to reopen the port; while it stays mute, it
// says so again after twice as long each time, up to `longest`. Pure: counters and time in.
#pragma once

#include <cstdint>
#include <optional>

#include "master/bus_plan.hpp"
#include "master/snapshot.hpp"
#include "rtu/timing.hpp"

namespace drivebus::master {

class MuteWatch {
public:
    // `after`: nullopt, the watch is off.
    MuteWatch(std::optional<Duration> after, Duration longest);

    // The port was opened at `now`, with the line's counters as they are.
    void opened(const BusCounters& counters, rtu::Instant now);
    // True when the port should be reopened now; then opened() again once it is.
    [[nodiscard]] bool mute(const BusCounters& counters, rtu::Instant now);
    // When mute() could next turn true, if the port is open and the watch on.
    [[nodiscard]] std::optional<rtu::Instant> next_check() const;
    // How long the line had been silent when mute() last turned true.
    [[nodiscard]] Duration silent_for() const noexcept { return silent_for_; }

private:
    [[nodiscard]] static std::uint64_t heard(const BusCounters& c) noexcept;

    std::optional<Duration> after_;
    Duration longest_;
    Duration wait_{};  // the silence that counts as mute now: `after`, doubled by each reopen
    bool open_ = false;
    std::uint64_t heard_ = 0;
    std::uint64_t timeouts_ = 0;
    rtu::Instant last_heard_{};
    Duration silent_for_{};
};

}  // namespace drivebus::master
