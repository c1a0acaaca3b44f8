// SPDX-License-Identifier: Apache-2.0
#include "master/line_budget.hpp"

#include <fmt/format.h>

#include "master/scheduler.hpp"

namespace drivebus::master {
namespace {

constexpr std::size_t kReadRequestBytes = 8;  // address, function, start, quantity, CRC
constexpr std::size_t kReadReplyBytes = 5;    // address, function, byte count, CRC

double milliseconds(rtu::Duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
}

}  // namespace

rtu::Duration poll_line_time(const DrivePlan& drive, const PollGroup& group, const rtu::CharacterTiming& timing) {
    rtu::Duration total{};
    if (!drive.profile) {
        return total;
    }
    for (const ReadChunk& chunk : plan_reads(group, *drive.profile, limits_of(*drive.profile))) {
        const std::size_t bytes = kReadRequestBytes + kReadReplyBytes + 2U * chunk.quantity;
        total += rtu::wire_time(timing, bytes) + 2 * timing.t3_5;
    }
    return total;
}

std::vector<std::string> line_budget_warnings(const BusPlan& bus) {
    std::vector<std::string> lines;
    const auto timing = rtu::character_timing(bus.format);
    if (!timing) {
        return lines;  // the configuration check has refused the format already
    }
    double share = 0;
    for (const auto& drive : bus.drives) {
        for (const auto& group : drive.polls) {
            const rtu::Duration need = poll_line_time(drive, group, *timing);
            if (group.period.count() <= 0) {
                continue;
            }
            share += static_cast<double>(need.count()) / static_cast<double>(group.period.count());
            if (need > group.period) {
                lines.push_back(fmt::format(
                    "bus '{}' drive '{}' poll '{}': its reads take at least {:.1f} ms of line time, more than its "
                    "period of {:.1f} ms: it will be read as often as the line allows, not every period",
                    bus.name, drive.name, group.name, milliseconds(need), milliseconds(group.period)));
            }
        }
    }
    if (share > 1.0) {
        lines.push_back(fmt::format(
            "bus '{}': its poll groups need at least {:.0f}% of the line's time (before the drives' own response "
            "times): they will be read less often than configured; lengthen their periods or raise the baud rate",
            bus.name, 100.0 * share));
    }
    return lines;
}

}  // namespace drivebus::master
