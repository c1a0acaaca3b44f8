// SPDX-License-Identifier: Apache-2.0
// Test doubles for the serial seams: a UART whose TIOCSERGETLSR answers are scripted and
// whose RTS calls are recorded, and a GPIO line that records what it was set to.
#pragma once

#include <chrono>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "serial/direction.hpp"
#include "serial/port.hpp"

namespace drivebus::serial::test {

using namespace std::chrono_literals;

// A fixed origin far from the clock's epoch, so that "before" is always representable.
inline const rtu::Instant kT0 = rtu::Instant{} + 1000s;

class FakeUart final : public UartControl {
public:
    // Answers to TIOCSERGETLSR in order; once used up, `otherwise`.
    std::deque<std::optional<bool>> script;
    std::optional<bool> otherwise = std::nullopt;
    int lsr_calls = 0;
    struct RtsCall {
        int fd;
        bool on;
        friend bool operator==(const RtsCall&, const RtsCall&) = default;
    };
    std::vector<RtsCall> rts;
    bool fail_rts = false;

    std::optional<bool> transmitter_empty(int /*fd*/) override {
        ++lsr_calls;
        if (script.empty()) {
            return otherwise;
        }
        const auto answer = script.front();
        script.pop_front();
        return answer;
    }
    std::expected<void, sys::SysError> set_rts(int fd, bool on) override {
        if (fail_rts) {
            return std::unexpected(sys::SysError{on ? "TIOCMBIS" : "TIOCMBIC", ENOTTY});
        }
        rts.push_back({fd, on});
        return {};
    }
};

class RecordingLine final : public OutputLine {
public:
    explicit RecordingLine(std::vector<bool>& sets, const bool& fail) : sets_(&sets), fail_(&fail) {}
    std::expected<void, DirectionError> set(bool active) override {
        if (*fail_) {
            return std::unexpected(DirectionError{"gpio test line 1: setting it failed: Input/output error"});
        }
        sets_->push_back(active);
        return {};
    }

private:
    std::vector<bool>* sets_;
    const bool* fail_;
};

}  // namespace drivebus::serial::test
