// SPDX-License-Identifier: Apache-2.0
#include "master/comm_timeout.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace drivebus::master {
namespace {

std::optional<std::uint16_t> word(const Result& result) {
    if (result.outcome != Outcome::Ok || !result.response) {
        return std::nullopt;
    }
    const auto* w = std::get_if<rtu::ReadHoldingRegistersResponse>(&*result.response);
    if (w == nullptr || w->values.size() != 1) {
        return std::nullopt;
    }
    return w->values[0];
}

std::uint8_t exception_of(const Result& result) {
    const auto e = result.exception();
    return e ? static_cast<std::uint8_t>(*e) : 0;
}

const RegisterInfo* timeout_register(const Profile& profile) {
    if (!profile.safety || profile.safety->comm_timeout.empty()) {
        return nullptr;
    }
    const RegisterInfo* r = profile.find(std::string_view(profile.safety->comm_timeout));
    return r != nullptr && r->address ? r : nullptr;
}

std::string seconds(double ms) {
    return fmt::format("{:g} s", ms / 1000.0);
}
std::string seconds(Duration d) {
    return seconds(std::chrono::duration<double, std::milli>(d).count());
}

// "F603 = 1 (Deceleration stop (Err5))".
std::string register_text(const Profile& profile, const std::string& name, std::uint16_t raw) {
    const RegisterInfo* r = profile.find(std::string_view(name));
    if (r != nullptr) {
        if (const auto meaning = r->values.find(raw); meaning != r->values.end()) {
            return fmt::format("{} = {} ({})", name, raw, meaning->second);
        }
    }
    return fmt::format("{} = {}", name, raw);
}

// Why the gap is what it is: "keep-alive 1 s, fastest poll 500 ms, plus 300 ms for an exchange ahead".
std::string gap_text(const BusPlan& bus, const DrivePlan& drive, std::optional<Duration> gap) {
    if (!gap) {
        return "neither a keep-alive nor a poll group sends it requests: only clients do";
    }
    return fmt::format("drivebusd may leave up to {} between two requests to it", seconds(*gap)) +
           fmt::format(" (keep-alive {}, fastest poll {}, plus {} for an exchange ahead of it)",
                       drive.keep_alive ? seconds(*drive.keep_alive) : std::string("off"),
                       drive.polls.empty() ? std::string("none")
                                           : seconds(std::ranges::min(drive.polls, {}, &PollGroup::period).period),
                       seconds(bus.response_timeout * (1 + bus.retries)));
}

}  // namespace

std::optional<Duration> longest_request_gap(const BusPlan& bus, const DrivePlan& drive) {
    std::optional<Duration> every = drive.keep_alive;
    for (const PollGroup& group : drive.polls) {
        if (!group.registers.empty() && group.period.count() > 0 && (!every || group.period < *every)) {
            every = group.period;
        }
    }
    if (!every) {
        return std::nullopt;
    }
    return *every + bus.response_timeout * (1 + bus.retries);
}

CommTimeoutNote::Verdict judge_comm_timeout(std::uint32_t timeout_ms, std::optional<Duration> gap) {
    if (timeout_ms == 0) {
        return CommTimeoutNote::Verdict::Off;
    }
    if (!gap || std::chrono::milliseconds(timeout_ms) <= *gap) {
        return CommTimeoutNote::Verdict::MayFire;
    }
    return CommTimeoutNote::Verdict::Fine;
}

std::optional<std::uint16_t> comm_timeout_raw(const DrivePlan& drive) {
    if (!drive.comm_timeout || !drive.profile) {
        return std::nullopt;
    }
    const RegisterInfo* r = timeout_register(*drive.profile);
    if (r == nullptr) {
        return std::nullopt;
    }
    const double counts =
        std::chrono::duration<double>(*drive.comm_timeout).count() / drive.profile->safety->comm_timeout_seconds;
    const double whole = std::round(counts);
    if (std::abs(counts - whole) > 1e-6 || whole < 0 || whole > 65535) {
        return std::nullopt;
    }
    const auto raw = static_cast<std::uint16_t>(whole);
    return r->in_range(raw) ? std::optional(raw) : std::nullopt;
}

CommTimeoutCheck::CommTimeoutCheck(rtu::SlaveAddress address, const Profile& profile,
                                   std::optional<std::uint16_t> wanted, std::optional<Duration> gap)
    : address_(address), wanted_(wanted), gap_(gap) {
    const RegisterInfo* timeout = timeout_register(profile);
    if (timeout == nullptr) {
        return;
    }
    safety_ = &*profile.safety;
    has_timeout_ = true;
    timeout_ = *timeout->address;
    if (const RegisterInfo* action = profile.find(std::string_view(safety_->comm_fault_action));
        action != nullptr && action->address) {
        action_ = *action->address;
    }
    restart();
}

void CommTimeoutCheck::restart() noexcept {
    step_ = has_timeout_ ? Step::Read : Step::End;
    note_ = {};
    note_.wanted = wanted_;
    note_.wanted_ms = wanted_ && safety_ != nullptr ? safety_->milliseconds(*wanted_) : 0;
    note_.gap = gap_;
}

std::optional<rtu::RequestAdu> CommTimeoutCheck::next() const {
    switch (step_) {
    case Step::Read:
    case Step::ReadBack: return rtu::RequestAdu{address_, rtu::ReadHoldingRegisters{timeout_, 1}};
    case Step::Write: return rtu::RequestAdu{address_, rtu::WriteSingleRegister{timeout_, *wanted_}};
    case Step::Action: return rtu::RequestAdu{address_, rtu::ReadHoldingRegisters{*action_, 1}};
    case Step::End: break;
    }
    return std::nullopt;
}

void CommTimeoutCheck::after_timeout() {
    const bool known = note_.state == CommTimeoutNote::State::Read || note_.state == CommTimeoutNote::State::Written ||
                       note_.state == CommTimeoutNote::State::WriteRefused ||
                       note_.state == CommTimeoutNote::State::ReadBack;
    if (known) {
        note_.timeout_ms = safety_->milliseconds(note_.raw);
        note_.verdict = judge_comm_timeout(note_.timeout_ms, gap_);
    }
    step_ = action_ ? Step::Action : Step::End;
}

bool CommTimeoutCheck::take(const Result& result) {
    using State = CommTimeoutNote::State;
    switch (step_) {
    case Step::Read:
        if (const auto value = word(result)) {
            note_.raw = *value;
            note_.state = State::Read;
            if (wanted_ && *value != *wanted_) {
                step_ = Step::Write;  // written only when it differs: the drive keeps it in EEPROM
                return false;
            }
        } else {
            note_.state = State::ReadRefused;
            note_.exception = exception_of(result);
        }
        after_timeout();
        break;
    case Step::Write:
        if (result.outcome == Outcome::Ok) {
            step_ = Step::ReadBack;
            return false;
        }
        note_.state = State::WriteRefused;
        note_.exception = exception_of(result);
        after_timeout();
        break;
    case Step::ReadBack:
        if (const auto value = word(result)) {
            note_.raw = *value;
            note_.state = *value == *wanted_ ? State::Written : State::ReadBack;
        } else {
            // Written, but it could not be read back: what the drive holds is not known.
            note_.state = State::ReadRefused;
            note_.exception = exception_of(result);
        }
        after_timeout();
        break;
    case Step::Action:
        if (const auto value = word(result)) {
            note_.action = *value;
            note_.action_read = true;
        }
        step_ = Step::End;
        break;
    case Step::End: break;
    }
    return step_ == Step::End;
}

std::vector<std::string> comm_timeout_warnings(const BusPlan& bus) {
    std::vector<std::string> lines;
    for (const DrivePlan& drive : bus.drives) {
        const RegisterInfo* r = drive.profile ? timeout_register(*drive.profile) : nullptr;
        if (r == nullptr) {
            continue;
        }
        const auto& safety = *drive.profile->safety;
        std::string which;
        std::uint32_t ms = 0;
        if (const auto raw = comm_timeout_raw(drive)) {
            which = fmt::format("its comm_timeout of {}", seconds(safety.milliseconds(*raw)));
            ms = safety.milliseconds(*raw);
        } else if (r->default_value) {
            // Not the drive's own value, which is read when it comes online: the factory one.
            ms = safety.milliseconds(static_cast<std::uint16_t>(*r->default_value));
            which = fmt::format("{} at its factory setting ({}; what the drive holds is read when it comes online)",
                                r->name, ms == 0 ? "off" : seconds(ms));
        } else {
            continue;
        }
        const auto gap = longest_request_gap(bus, drive);
        const auto where = fmt::format("bus '{}' drive '{}': ", bus.name, drive.name);
        switch (judge_comm_timeout(ms, gap)) {
        case CommTimeoutNote::Verdict::Off:
            lines.push_back(where + which +
                            " turns the drive's Modbus time-out off: if the line or drivebusd dies, the drive runs "
                            "on at its last command");
            break;
        case CommTimeoutNote::Verdict::MayFire:
            lines.push_back(where + which +
                            " is not longer than the time between requests: " + gap_text(bus, drive, gap) +
                            ", so the drive may trip on a healthy line; set keep_alive shorter than the time-out");
            break;
        case CommTimeoutNote::Verdict::Fine:
        case CommTimeoutNote::Verdict::None: break;
        }
    }
    return lines;
}

std::optional<CommTimeoutLine> comm_timeout_line(const BusPlan& bus, const DrivePlan& drive,
                                                 const CommTimeoutNote& note) {
    using State = CommTimeoutNote::State;
    if (!drive.profile || !drive.profile->safety || note.state == State::Unknown) {
        return std::nullopt;
    }
    const Profile& p = *drive.profile;
    const auto& safety = *p.safety;
    const std::string& reg = safety.comm_timeout;
    const auto where = fmt::format("bus {} drive {}: Modbus time-out ", bus.name, drive.name);
    const auto value = [&](std::uint16_t raw) {
        const auto ms = safety.milliseconds(raw);
        return fmt::format("{} = {} ({})", reg, raw, ms == 0 ? std::string("off") : seconds(ms));
    };
    const auto action =
        note.action_read ? "; on a time-out: " + register_text(p, safety.comm_fault_action, note.action) : "";
    const auto refused = [&] {
        return note.exception != 0 ? fmt::format("exception {}", note.exception) : std::string("no valid reply");
    };
    CommTimeoutLine line;
    line.warning = true;
    switch (note.state) {
    case State::Unknown: return std::nullopt;
    case State::ReadRefused: line.text = where + fmt::format("{} could not be read ({})", reg, refused()); return line;
    case State::WriteRefused:
        line.text = where + fmt::format("{} was not written {} ({}); the drive holds ", reg, *note.wanted, refused()) +
                    value(note.raw);
        break;
    case State::ReadBack:
        line.text = where + fmt::format("{} was written {} and reads back {}", reg, *note.wanted, note.raw);
        break;
    case State::Written: line.text = where + value(note.raw) + ", written as configured"; break;
    case State::Read: line.text = where + value(note.raw); break;
    }
    line.text += action;
    switch (note.verdict) {
    case CommTimeoutNote::Verdict::Off:
        line.text +=
            ": off, so if the line or drivebusd dies the drive runs on at its last command; set comm_timeout "
            "in drivebusd's configuration, or " +
            reg + " on the drive";
        break;
    case CommTimeoutNote::Verdict::MayFire:
        line.text += ": not longer than the time between requests: " + gap_text(bus, drive, note.gap) +
                     ", so the drive may trip on a healthy line; set keep_alive shorter than the time-out";
        break;
    case CommTimeoutNote::Verdict::Fine:
    case CommTimeoutNote::Verdict::None: line.warning = note.state != State::Read && note.state != State::Written;
    }
    return line;
}

}  // namespace drivebus::master
