// SPDX-License-Identifier: Apache-2.0
// Real-time set-up of the bus threads: SCHED_FIFO and CPU affinity (locked memory: memory.hpp).
#pragma once

#include <expected>
#include <optional>
#include <string>
#include <vector>

namespace drivebus::rt {

// SCHED_FIFO at `priority` and, if `cpus` is not empty, affinity to them, for the calling thread.
[[nodiscard]] std::expected<void, std::string> make_realtime(int priority, const std::vector<int>& cpus);

// A bus's service thread (client requests, control-lease expiry and the fallback write to a
// drive whose application went quiet) runs real-time too, this far under the bus threads: at
// normal priority a busy machine delays the fallback (a stop) by as long as it likes; at the
// bus threads' priority it could delay a request on the wire.
inline constexpr int kServiceBelowBus = 10;
// Its SCHED_FIFO priority when the bus threads have `bus_priority`: kServiceBelowBus under it,
// at least 1; nullopt at priority 1, with nothing under it (the thread stays at normal priority).
[[nodiscard]] std::optional<int> service_priority(int bus_priority);

}  // namespace drivebus::rt
