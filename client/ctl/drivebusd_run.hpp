// SPDX-License-Identifier: Apache-2.0
// What only drivebusd can say, asked of drivebusd: its configuration reader (drivebusd.toml, its
// drivebusd.toml.d fragments, the profiles) and its bus thread are drivebusd's, which a
// libdrivebus client does not link. DRIVEBUSD names another drivebusd (a build tree's).
#pragma once

#include <expected>
#include <string>
#include <vector>

namespace drivebus::ctl {

// DRIVEBUSD when set and not empty, else where the drivebusd package puts it.
[[nodiscard]] std::string drivebusd_program();

struct DrivebusdRun {
    int exit_code = 0;  // drivebusd's; 128 + N when killed by signal N
    std::string out;    // its standard output
    std::string err;    // its standard error
};

// Runs drivebusd_program() with `args` (after argv[0]) to its end, its output kept; standard
// input is /dev/null. The error is why it could not be run ("cannot run /usr/sbin/drivebusd:
// No such file or directory").
[[nodiscard]] std::expected<DrivebusdRun, std::string> run_drivebusd(const std::vector<std::string>& args);

}  // namespace drivebus::ctl
