// SPDX-License-Identifier: Apache-2.0
// Commands of the control socket and the --fault / --option command-line arguments, applied
// to a Bus. One line in, one line out.
#pragma once

#include <expected>
#include <string>
#include <string_view>

#include "bus.hpp"

namespace drivebus::sim {

// Runs one control command; returns "ok ..." or "error: ...". `line_idle`: nothing the master
// sent is waiting to be read and no frame is being received (the command `idle` says it).
[[nodiscard]] std::string run_command(Bus& bus, std::string_view line, rtu::Instant now, bool line_idle = true);

// "[ADDR:]key=value", as --fault takes it.
[[nodiscard]] std::expected<void, std::string> apply_fault_argument(Bus& bus, std::string_view argument);
// "ADDR:key=value", as --option takes it.
[[nodiscard]] std::expected<void, std::string> apply_option_argument(Bus& bus, std::string_view argument);
// "ADDR:REG=VALUE", as --set takes it: a register's value from the start (F803=0: a drive whose
// Modbus time-out is off), as the control socket's `set`.
[[nodiscard]] std::expected<void, std::string> apply_set_argument(Bus& bus, std::string_view argument);

}  // namespace drivebus::sim
