// Real-time set-up of the bus threads: SCHED_FIFO and CPU affinity (locked memory: memory.hpp).
#pragma once

#include <expected>
#include <string>
#include <vector>

namespace drivebus::rt {

// SCHED_FIFO at `priority` and, if `cpus` is not empty, affinity to them, for the calling thread.
[[nodiscard]] std::expected<void, std::string> make_realtime(int priority, const std::vector<int>& cpus);

}  // namespace drivebus::rt
