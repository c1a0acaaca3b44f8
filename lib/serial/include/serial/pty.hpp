// SPDX-License-Identifier: Apache-2.0
// A pseudo-terminal pair standing in for a serial line: one program holds the master side,
// another opens the slave side (/dev/pts/N) as if it were /dev/ttyS0.
#pragma once

#include <expected>
#include <filesystem>
#include <string>

#include "sys/posix.hpp"

namespace drivebus::serial {

struct PtyPair {
    sys::UniqueFd master;
    // Held open so that the line does not hang up between the programs that open the slave.
    sys::UniqueFd slave;
    std::filesystem::path slave_path;
};

// Opens a pty pair, both ends non-blocking and raw.
[[nodiscard]] std::expected<PtyPair, sys::SysError> open_pty();

}  // namespace drivebus::serial
