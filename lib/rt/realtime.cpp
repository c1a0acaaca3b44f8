// SPDX-License-Identifier: Apache-2.0
#include "rt/realtime.hpp"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cstring>

namespace drivebus::rt {

std::expected<void, std::string> make_realtime(int priority, const std::vector<int>& cpus) {
    if (!cpus.empty()) {
        cpu_set_t set;
        CPU_ZERO(&set);
        for (const int cpu : cpus) {
            CPU_SET(static_cast<unsigned>(cpu), &set);
        }
        if (const int rc = ::pthread_setaffinity_np(::pthread_self(), sizeof set, &set); rc != 0) {
            return std::unexpected(std::string("CPU affinity: ") + std::strerror(rc));
        }
    }
    sched_param param{};
    param.sched_priority = priority;
    if (const int rc = ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &param); rc != 0) {
        return std::unexpected(std::string("SCHED_FIFO priority ") + std::to_string(priority) + ": " +
                               std::strerror(rc) + " (needs CAP_SYS_NICE or an rtprio limit)");
    }
    return {};
}

std::optional<int> service_priority(int bus_priority) {
    if (bus_priority <= 1) {
        return std::nullopt;
    }
    return std::max(bus_priority - kServiceBelowBus, 1);
}

}  // namespace drivebus::rt
