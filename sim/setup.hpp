// SPDX-License-Identifier: Apache-2.0
// drivebus-sim's start-up: its options, the drives they name and the line it serves them on.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "bus.hpp"
#include "rtu/timing.hpp"
#include "serial/pty.hpp"
#include "sys/posix.hpp"

namespace drivebus::sim {

inline constexpr int kExitUsage = 2;
inline constexpr int kExitRuntime = 1;

struct Options {
    std::string link;
    std::string device;
    std::vector<std::string> drives;
    std::uint32_t baud = 19200;
    unsigned data_bits = 8;
    std::string parity = "none";
    unsigned stop_bits = 1;
    bool pace = true;
    std::string turnaround = "1ms";
    std::vector<std::string> faults;
    std::vector<std::string> drive_options;
    std::vector<std::string> registers;  // --set ADDR:REG=VALUE
    std::string control;
    std::uint32_t seed = 1;
    std::string profile_dir;
    int realtime = 0;
    std::string tx_log;
    std::string rx_log;
};

struct Line {
    sys::UniqueFd fd;  // what the simulator reads and writes
    std::optional<serial::PtyPair> pty;
    std::filesystem::path link;  // removed on exit
    std::string description;
};

// Prints "drivebus-sim: MESSAGE" and exits with `code`.
[[noreturn]] void fail(int code, const std::string& message);

[[nodiscard]] rtu::LineFormat line_format(const Options& o);
// The drives of --drive, each set to the line's format; a bad one ends the program (usage).
void add_drives(const Options& o, Bus& bus, const rtu::LineFormat& format);
// A pty with its link (--link), or the tty of --device, set to the format.
[[nodiscard]] Line open_line(const Options& o, const rtu::LineFormat& format);
// Removes the link if it still points at this line's pty.
void remove_link(const Line& line);

// An inotify descriptor that turns readable when someone opens the pty's side a master uses
// (-1 for a tty given with --device, or when inotify is refused); drain_opens() reads its
// events and says whether one was an open.
[[nodiscard]] sys::UniqueFd watch_opens(const Line& line);
[[nodiscard]] bool drain_opens(int fd);

}  // namespace drivebus::sim
