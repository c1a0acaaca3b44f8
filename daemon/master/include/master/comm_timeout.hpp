// SPDX-License-Identifier: Apache-2.0
// The drive's own Modbus time-out (its profile's [safety]: the ATV21's F803, with F603 for what
// it does when it fires), which is what stops a drive whose master has died.
//
// When a drive comes online drivebusd reads the time-out; where the configuration asks for a
// value (`comm_timeout`) and the drive holds another, it writes it and reads it back, as it does
// the block selectors; then it reads the fault behaviour. The value found is judged against the
// longest drivebusd may leave between two requests to the drive:
//   - off: if the line, the adapter or drivebusd dies, the drive runs on at its last command;
//   - not longer than that gap: the drive may trip on a healthy line.
// The check runs once per coming online and never holds the drive back: a drive whose time-out
// cannot be read or written is polled as any other, and the note says what happened.
//
// Pure: the scheduler sends the requests and hands back each result.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivebus/profile.hpp"
#include "master/bus_plan.hpp"
#include "master/result.hpp"
#include "master/snapshot.hpp"
#include "rtu/pdu.hpp"

namespace drivebus::master {

// The longest drivebusd may leave between two requests to `drive` while it answers: its
// keep-alive or its fastest poll period, whichever is shorter, plus one exchange that may hold
// the line when the request falls due (a request sent through every retry). nullopt when
// neither is configured: then only clients' requests reach the drive.
[[nodiscard]] std::optional<Duration> longest_request_gap(const BusPlan& bus, const DrivePlan& drive);

// What a time-out of `timeout_ms` (0: off) means with that gap.
[[nodiscard]] CommTimeoutNote::Verdict judge_comm_timeout(std::uint32_t timeout_ms, std::optional<Duration> gap);

// The configured comm_timeout in raw counts of the profile's time-out register; nullopt when
// none is configured, the profile names no time-out, or it is not a whole number of counts in
// the register's range (the configuration refuses those).
[[nodiscard]] std::optional<std::uint16_t> comm_timeout_raw(const DrivePlan& drive);

class CommTimeoutCheck {
public:
    CommTimeoutCheck() = default;
    CommTimeoutCheck(rtu::SlaveAddress address, const Profile& profile, std::optional<std::uint16_t> wanted,
                     std::optional<Duration> gap);

    // The profile names no time-out: nothing to do.
    [[nodiscard]] bool empty() const noexcept { return !has_timeout_; }
    // From the first step, the note forgotten: the drive (re)came online.
    void restart() noexcept;
    [[nodiscard]] bool running() const noexcept { return step_ != Step::End; }
    // The next request; nullopt once finished.
    [[nodiscard]] std::optional<rtu::RequestAdu> next() const;
    // The result of the request next() gave; true when that finished the check.
    bool take(const Result& result);
    [[nodiscard]] const CommTimeoutNote& note() const noexcept { return note_; }

private:
    enum class Step : std::uint8_t { Read, Write, ReadBack, Action, End };
    void after_timeout();

    rtu::SlaveAddress address_ = 0;
    const SafetyInfo* safety_ = nullptr;
    bool has_timeout_ = false;
    std::uint16_t timeout_ = 0;  // the registers
    std::optional<std::uint16_t> action_;
    std::optional<std::uint16_t> wanted_;
    std::optional<Duration> gap_;
    Step step_ = Step::End;
    CommTimeoutNote note_;
};

// What `drivebusd --check-config` can say without the drives: each drive's configured
// comm_timeout, or else its profile's factory setting, against the longest gap between requests.
[[nodiscard]] std::vector<std::string> comm_timeout_warnings(const BusPlan& bus);

// The one log line for a drive's finished check: a warning when the time-out is off, may fire,
// or could not be read or written as configured; else information.
struct CommTimeoutLine {
    bool warning = false;
    std::string text;
};
[[nodiscard]] std::optional<CommTimeoutLine> comm_timeout_line(const BusPlan& bus, const DrivePlan& drive,
                                                               const CommTimeoutNote& note);

}  // namespace drivebus::master
