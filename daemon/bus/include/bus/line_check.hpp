// SPDX-License-Identifier: Apache-2.0
// drivebusd --check-line (and drivebusctl line-check): what a bus's line does before
// commissioning, run by the code drivebusd runs. For each bus: the port opened as drivebusd
// opens it and its low-latency tuning, whether the driver reports an empty transmitter, the
// driver-enable control (for "kernel", the RS485 settings as found and as the driver kept
// them; for "gpio", the line requested), then one read of each drive through the bus thread
// and its master, and the line's counters. The line must be free: drivebusd stopped.
#pragma once

#include <ostream>
#include <string>

#include "config/config.hpp"

namespace drivebus::bus {

struct LineCheckOptions {
    std::string bus;  // only this bus; empty: every bus
};

// Prints the report on `out`. Returns the exit code: 0 when every line opened with its
// driver-enable control and every drive answered; 78 for what the configuration asks and the
// machine cannot give (as drivebusd would exit at start) or a bus that is not configured; 1
// otherwise (a port that is missing or in use, a drive that did not answer).
[[nodiscard]] int check_lines(const config::Config& config, const LineCheckOptions& options, std::ostream& out);

}  // namespace drivebus::bus
