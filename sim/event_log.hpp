// SPDX-License-Identifier: Apache-2.0
// --tx-log and --rx-log: one text line per reply sent or request received, for benchmarks
// that line the simulator's clock up against a master's or a client's (both CLOCK_MONOTONIC):
//
//   NS ADDRESS FUNCTION
//
// NS in nanoseconds, ADDRESS and FUNCTION in decimal. Lines are buffered and written out when
// the buffer fills and when the simulator stops, so that logging costs the line no time.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "rtu/timing.hpp"

namespace drivebus::sim {

class EventLog {
public:
    // Nothing is logged when `path` is empty. Throws when the file cannot be created.
    explicit EventLog(const std::string& path);

    [[nodiscard]] bool enabled() const noexcept { return file_ != nullptr; }
    void record(rtu::Instant at, std::uint8_t address, std::uint8_t function);

private:
    struct Close {
        void operator()(std::FILE* f) const noexcept { std::fclose(f); }
    };
    std::vector<char> buffer_;  // declared first: fclose() flushes it
    std::unique_ptr<std::FILE, Close> file_;
};

}  // namespace drivebus::sim
