// SPDX-License-Identifier: Apache-2.0
// drivebusctl's commands, on libdrivebus. Each returns the exit status; errors are reported
// with report() (one line on stderr, and a JSON error on stdout with --json).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "drivebus/client.hpp"

namespace drivebus::ctl {

struct Options {
    std::string bus;  // empty: the only bus drivebusd announces
    bool json = false;
    std::chrono::milliseconds timeout{2000};
    std::string profile_dir;
};

// Prints "drivebusctl: CONTEXT: MESSAGE" on stderr (and the JSON error) and returns the exit
// status of the error's kind.
int report(const Options& options, const Error& error, const std::string& context = {});
// Prints text (or, with --json, one JSON document) on stdout.
void print(const std::string& text);

ConnectOptions connect_options(const Options& options);

int run_list(const Options& options);
int run_status(const Options& options, const std::string& drive);
int run_read(const Options& options, const std::string& drive, const std::string& reg, std::uint16_t count);
int run_write(const Options& options, const std::string& drive, const std::string& reg,
              const std::vector<std::string>& values, const WriteOptions& write_options);
int run_identify(const Options& options, const std::string& drive);
int run_scan(const Options& options, int from, int to, const std::string& reg);
int run_watch(const Options& options, std::chrono::milliseconds interval);  // watch.cpp

}  // namespace drivebus::ctl
