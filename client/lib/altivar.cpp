// SPDX-License-Identifier: Apache-2.0
#include "drivebus/altivar.hpp"

#include <cmath>

#include "bus_impl.hpp"

namespace drivebus {
namespace {

std::optional<std::uint16_t> value_of(const Profile& profile, const shm::DriveSnapshot& s, const std::string& name) {
    if (name.empty()) {
        return std::nullopt;
    }
    const auto* r = profile.find(name);
    if (r == nullptr || !r->address) {
        return std::nullopt;
    }
    const auto* sample = s.find(*r->address);
    if (sample == nullptr || sample->valid == 0) {
        return std::nullopt;
    }
    return sample->value;
}

bool bit(const ControlInfo& c, std::uint16_t word, const char* name) {
    const auto it = c.status_bits.find(name);
    return it != c.status_bits.end() && ((static_cast<unsigned>(word) >> it->second) & 1U) != 0;
}

// "Run/stop: 0 = stop, 1 = run" -> "Run/stop"
std::string short_meaning(const std::string& text) {
    const auto colon = text.find(':');
    return colon == std::string::npos ? text : text.substr(0, colon);
}

}  // namespace

DriveState decode_state(const Profile& profile, const shm::DriveSnapshot& s) {
    DriveState st;
    st.sequence = s.sequence;
    st.health = s.health;
    st.lease = s.lease;
    if (!profile.control) {
        return st;
    }
    const auto& c = *profile.control;
    if (const auto word = value_of(profile, s, c.status)) {
        st.status_word = word;
        st.running = bit(c, *word, "running");
        st.reverse = bit(c, *word, "reverse");
        st.fault = bit(c, *word, "fault");
        st.alarm = bit(c, *word, "alarm");
        st.ready = bit(c, *word, "ready");
        if (const auto* r = profile.find(c.status)) {
            for (const auto& [n, meaning] : r->bits) {
                if (((static_cast<unsigned>(*word) >> n) & 1U) != 0) {
                    st.flags.push_back(short_meaning(meaning));
                }
            }
        }
    }
    if (const auto raw = value_of(profile, s, c.output_frequency)) {
        st.output_hz = profile.find(c.output_frequency)->to_engineering(*raw);
    }
    if (const auto code = value_of(profile, s, c.fault)) {
        st.fault_code = code;
        if (const auto* f = profile.fault(*code)) {
            st.fault_name = f->name;
            st.fault_title = f->title;
        }
    }
    if (const auto alarms = value_of(profile, s, c.alarm)) {
        if (const auto* r = profile.find(c.alarm)) {
            for (const auto& [n, meaning] : r->bits) {
                if (((static_cast<unsigned>(*alarms) >> n) & 1U) != 0) {
                    st.alarms.push_back(short_meaning(meaning));
                }
            }
        }
    }
    return st;
}

std::expected<void, Error> Altivar::set_frequency(double hz, WriteOptions options) const {
    const auto* profile = drive_.profile();
    if (profile == nullptr) {
        return std::unexpected(make_error(ErrorKind::Unsupported, "drive '" + drive_.name() + "': it has no profile"));
    }
    const auto reference = frequency_reference(*profile);
    if (!reference) {
        return std::unexpected(
            make_error(ErrorKind::Unsupported, "drive '" + drive_.name() + "': " + reference.error()));
    }
    const auto* r = *reference;
    const auto raw = r->from_engineering(hz);
    if (!raw || !r->in_range(*raw)) {
        return std::unexpected(make_error(ErrorKind::InvalidArgument, "drive '" + drive_.name() +
                                                                          "': " + std::to_string(hz) + " " + r->unit +
                                                                          " is outside what " + r->name + " takes"));
    }
    const std::uint16_t word = *raw;
    return drive_.write(*r->address, std::span(&word, 1), options);
}

std::expected<void, Error> Altivar::command(const std::optional<std::uint16_t> ControlInfo::* word, const char* what,
                                            WriteOptions options) const {
    const auto* profile = drive_.profile();
    if (profile == nullptr || !profile->control || !(profile->control.value().*word) ||
        profile->control->command.empty()) {
        return std::unexpected(make_error(ErrorKind::Unsupported, "drive '" + drive_.name() + "': profile " +
                                                                      (profile ? profile->type : std::string("?")) +
                                                                      " gives no command word to " + what));
    }
    const std::uint16_t value = *(profile->control.value().*word);
    return drive_.write(profile->control->command, std::span(&value, 1), options);
}

std::expected<void, Error> Altivar::run_forward(WriteOptions options) const {
    return command(&ControlInfo::run_forward, "run forward", options);
}
std::expected<void, Error> Altivar::run_reverse(WriteOptions options) const {
    return command(&ControlInfo::run_reverse, "run in reverse", options);
}
std::expected<void, Error> Altivar::stop(WriteOptions options) const {
    return command(&ControlInfo::stop, "stop", options);
}
std::expected<void, Error> Altivar::freewheel(WriteOptions options) const {
    return command(&ControlInfo::freewheel, "freewheel", options);
}
std::expected<void, Error> Altivar::reset_fault(WriteOptions options) const {
    return command(&ControlInfo::fault_reset, "reset a fault", options);
}

std::expected<DriveState, Error> Altivar::state(Milliseconds wait) const {
    auto snapshot = drive_.wait_snapshot(wait);
    if (!snapshot) {
        return std::unexpected(snapshot.error());
    }
    if (drive_.profile() == nullptr) {
        return std::unexpected(make_error(ErrorKind::Unsupported, "drive '" + drive_.name() + "': no profile"));
    }
    return decode_state(*drive_.profile(), *snapshot);
}

}  // namespace drivebus
