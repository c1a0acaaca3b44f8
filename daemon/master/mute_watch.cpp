// SPDX-License-Identifier: Apache-2.0
#include "master/mute_watch.hpp"

#include <algorithm>
#include <numeric>

namespace drivebus::master {

MuteWatch::MuteWatch(std::optional<Duration> after, Duration longest)
    : after_(after), longest_(after ? std::max(longest, *after) : longest), wait_(after.value_or(Duration{})) {}

// Anything the line delivered: a mute adapter delivers nothing, a drive that answers wrongly
// still proves the adapter works.
std::uint64_t MuteWatch::heard(const BusCounters& c) noexcept {
    return std::accumulate(c.exceptions.begin(), c.exceptions.end(), std::uint64_t{0}) + c.replies + c.crc_errors +
           c.gap_errors + c.parity_errors + c.overflows + c.noise + c.foreign + c.malformed + c.echo_mismatches +
           c.late_replies;
}

void MuteWatch::opened(const BusCounters& counters, rtu::Instant now) {
    open_ = true;
    heard_ = heard(counters);
    timeouts_ = counters.timeouts;
    last_heard_ = now;
}

bool MuteWatch::mute(const BusCounters& counters, rtu::Instant now) {
    if (!after_ || !open_) {
        return false;
    }
    if (const auto h = heard(counters); h != heard_) {
        heard_ = h;
        timeouts_ = counters.timeouts;
        last_heard_ = now;
        wait_ = *after_;  // the line works: the next silence is judged afresh
        return false;
    }
    // Silence alone is no evidence: a bus with nothing to send hears nothing either.
    if (counters.timeouts == timeouts_ || now - last_heard_ < wait_) {
        return false;
    }
    silent_for_ = now - last_heard_;
    open_ = false;
    wait_ = std::min(wait_ * 2, longest_);
    return true;
}

std::optional<rtu::Instant> MuteWatch::next_check() const {
    if (!after_ || !open_) {
        return std::nullopt;
    }
    return last_heard_ + wait_;
}

}  // namespace drivebus::master
