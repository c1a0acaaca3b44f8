// SPDX-License-Identifier: Apache-2.0
// When received characters are taken to have arrived.
//
// On a pty a master's write arrives all at once. Paced, the simulator treats the bytes of a
// read as arriving at wire speed from the moment they were read, one character time apart
// (and never before the previous character has finished), as a drive on a real line would
// receive them. Unpaced (a real UART), the read returns after the characters arrived, so the
// read time is the last one's end.
#pragma once

#include <cstddef>
#include <optional>

#include "rtu/timing.hpp"

namespace drivebus::sim {

class ArrivalModel {
public:
    ArrivalModel(rtu::Duration character, bool paced) noexcept : character_(character), paced_(paced) {}

    // The end time of the last of `count` characters returned by a read at `read_time`.
    rtu::Instant place(std::size_t count, rtu::Instant read_time) noexcept {
        if (!paced_ || count == 0) {
            return read_time;
        }
        rtu::Instant first = read_time;
        if (last_ && *last_ + character_ > first) {
            first = *last_ + character_;
        }
        last_ = first + character_ * static_cast<std::int64_t>(count - 1);
        return *last_;
    }

private:
    rtu::Duration character_;
    bool paced_;
    std::optional<rtu::Instant> last_;
};

}  // namespace drivebus::sim
