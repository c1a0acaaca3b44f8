// SPDX-License-Identifier: Apache-2.0
// Small tools shared by the benchmark suite's items: processes, files, the clock, the table's
// rows and the suite's options.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim_process.hpp"
#include "stats.hpp"

namespace drivebus::bench {

namespace fs = std::filesystem;
using test::roudi_answers;
using test::roudi_gone;

struct Failure : std::runtime_error {
    using std::runtime_error::runtime_error;
};

std::int64_t now_ns();
double us(std::int64_t ns);
void note(const std::string& text);

// Waits (30 min at most) until no iceoryx RouDi answers on /tmp/roudi.
void wait_for_no_roudi();

std::string slurp(const fs::path& path);
fs::path fresh_dir(const std::string& what);
// A program started with its stdout in `out` (stderr in out + ".err"); its pid.
int spawn(const std::vector<std::string>& argv, const fs::path& out);
// Its exit status, or -1 when it was killed at `timeout` or by a signal.
int wait_exit(int pid, std::chrono::seconds timeout);

// The whitespace-separated integers of each non-empty line.
std::vector<std::vector<std::int64_t>> numbers(const std::string& text);

// A simulator log line: time, slave address, function code.
struct Event {
    std::int64_t ns = 0;
    int address = 0;
    int function = 0;
};
std::vector<Event> read_events(const fs::path& path);

// The value of `key=` in a "key=value key=value" line, "0" when absent.
std::string field(const std::string& summary, const std::string& key);

struct Row {
    std::string item{};
    std::string what{};
    std::size_t samples = 0;
    std::optional<bench::Summary> summary{};  // in microseconds
    std::string notes{};
    std::string target{};
    std::optional<bool> met{};
};

// A row of percentiles over `samples` (µs), without a target.
Row samples_row(std::string item, std::string what, const std::vector<double>& samples, std::string notes);
// A table cell: "164", "4.7".
std::string cell(double v);
// The rows as docs/performance.md's table (markdown).
std::string table(const std::vector<Row>& rows);

struct Options {
    bool smoke = false;
    std::size_t sample_count = 0;  // 0: 10,000, or 300 with --smoke
    [[nodiscard]] std::size_t samples() const { return sample_count > 0 ? sample_count : (smoke ? 300 : 10000); }
    std::set<int> only;
    std::string markdown;
    [[nodiscard]] bool runs(int item) const { return only.empty() || only.contains(item); }
};

}  // namespace drivebus::bench
