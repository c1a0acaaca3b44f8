// SPDX-License-Identifier: Apache-2.0
// Low-latency tuning of a serial port where the driver offers it. Nothing here fails an open:
// each step leaves one line for the log saying what was done or why not.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus::serial {

// The kernel's name for the tty behind `device` (symlinks such as /dev/serial/by-id/...
// followed): "ttyUSB0"; "pts/3" for a pseudo-terminal.
[[nodiscard]] std::string tty_name(const std::filesystem::path& device);

// On `fd`, the open tty `name`:
//   ASYNC_LOW_LATENCY through TIOCGSERIAL/TIOCSSERIAL;
//   FTDI: <sysfs_tty>/<name>/device/latency_timer (or device/../latency_timer) set to 1 ms,
//         from the 16 ms default that otherwise delays every reply by up to 16 ms;
//   8250: <sysfs_tty>/<name>/rx_trig_bytes set to the lowest level the UART has (writing 1
//         selects it), so a short reply raises an interrupt at its first byte, not at a FIFO
//         timeout of about 4 character times.
// Call after termios is set. `sysfs_tty` is a parameter for the tests.
[[nodiscard]] std::vector<std::string> apply_low_latency(int fd, std::string_view name,
                                                         const std::filesystem::path& sysfs_tty = "/sys/class/tty");

}  // namespace drivebus::serial
