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

// A register and the word to write there.
struct Word {
    std::uint16_t address = 0;
    std::uint16_t value = 0;
};

std::expected<Word, Error> reference_word(const Drive& drive, double hz) {
    const auto* profile = drive.profile();
    if (profile == nullptr) {
        return std::unexpected(make_error(ErrorKind::Unsupported, "drive '" + drive.name() + "': it has no profile"));
    }
    const auto reference = frequency_reference(*profile);
    if (!reference) {
        return std::unexpected(
            make_error(ErrorKind::Unsupported, "drive '" + drive.name() + "': " + reference.error()));
    }
    const auto* r = *reference;
    const auto raw = r->from_engineering(hz);
    if (!raw || !r->in_range(*raw)) {
        return std::unexpected(make_error(ErrorKind::InvalidArgument, "drive '" + drive.name() +
                                                                          "': " + std::to_string(hz) + " " + r->unit +
                                                                          " is outside what " + r->name + " takes"));
    }
    return Word{.address = *r->address, .value = *raw};
}

std::expected<Word, Error> command_word(const Drive& drive, const std::optional<std::uint16_t> ControlInfo::* word,
                                        const char* what) {
    const auto* profile = drive.profile();
    if (profile == nullptr || !profile->control || !(profile->control.value().*word) ||
        profile->control->command.empty()) {
        return std::unexpected(make_error(ErrorKind::Unsupported, "drive '" + drive.name() + "': profile " +
                                                                      (profile ? profile->type : std::string("?")) +
                                                                      " gives no command word to " + what));
    }
    const auto address = drive.resolve(profile->control->command);
    if (!address) {
        return std::unexpected(address.error());
    }
    return Word{.address = *address, .value = *(profile->control.value().*word)};
}

std::expected<void, Error> write(const Drive& drive, const std::expected<Word, Error>& word, WriteOptions options) {
    if (!word) {
        return std::unexpected(word.error());
    }
    return drive.write(word->address, std::span(&word->value, 1), options);
}

void async_write(const Drive& drive, const std::expected<Word, Error>& word, Drive::Done done, WriteOptions options) {
    if (!word) {
        done(std::unexpected(word.error()));
        return;
    }
    drive.async_write(word->address, std::span(&word->value, 1), std::move(done), options);
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
    return write(drive_, reference_word(drive_, hz), options);
}

std::expected<void, Error> Altivar::command(const std::optional<std::uint16_t> ControlInfo::* word, const char* what,
                                            WriteOptions options) const {
    return write(drive_, command_word(drive_, word, what), options);
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

void Altivar::async_set_frequency(double hz, Drive::Done done, WriteOptions options) const {
    async_write(drive_, reference_word(drive_, hz), std::move(done), options);
}
void Altivar::async_run_forward(Drive::Done done, WriteOptions options) const {
    async_write(drive_, command_word(drive_, &ControlInfo::run_forward, "run forward"), std::move(done), options);
}
void Altivar::async_run_reverse(Drive::Done done, WriteOptions options) const {
    async_write(drive_, command_word(drive_, &ControlInfo::run_reverse, "run in reverse"), std::move(done), options);
}
void Altivar::async_stop(Drive::Done done, WriteOptions options) const {
    async_write(drive_, command_word(drive_, &ControlInfo::stop, "stop"), std::move(done), options);
}
void Altivar::async_freewheel(Drive::Done done, WriteOptions options) const {
    async_write(drive_, command_word(drive_, &ControlInfo::freewheel, "freewheel"), std::move(done), options);
}
void Altivar::async_reset_fault(Drive::Done done, WriteOptions options) const {
    async_write(drive_, command_word(drive_, &ControlInfo::fault_reset, "reset a fault"), std::move(done), options);
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
