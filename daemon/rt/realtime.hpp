// Real-time set-up of the bus threads: SCHED_FIFO, CPU affinity, locked memory.
#pragma once

#include <expected>
#include <string>
#include <vector>

namespace drivebus::rt {

// mlockall(MCL_CURRENT | MCL_FUTURE) for the whole process.
[[nodiscard]] std::expected<void, std::string> lock_memory();
// SCHED_FIFO at `priority` and, if `cpus` is not empty, affinity to them, for the calling thread.
[[nodiscard]] std::expected<void, std::string> make_realtime(int priority, const std::vector<int>& cpus);

}  // namespace drivebus::rt
