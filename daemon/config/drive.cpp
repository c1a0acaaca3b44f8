// SPDX-License-Identifier: Apache-2.0
// One [[bus.drive]]: its profile, its address and line checked against that profile, its polls.
#include <algorithm>
#include <limits>
#include <set>

#include "drivebus/shm.hpp"
#include "master/comm_timeout.hpp"
#include "read.hpp"

namespace drivebus::config::detail {
namespace {

using namespace std::chrono_literals;

constexpr std::int64_t kAnyInteger = std::numeric_limits<std::int64_t>::max();

std::string parity_name(rtu::Parity parity) {
    switch (parity) {
    case rtu::Parity::None: return "none";
    case rtu::Parity::Even: return "even";
    case rtu::Parity::Odd: return "odd";
    }
    return "?";
}

template <typename T>
std::string joined(const std::vector<T>& values) {
    std::string out;
    for (const auto& value : values) {
        out.append(out.empty() ? "" : ", ");
        if constexpr (std::is_same_v<T, std::string>) {
            out.append(value);
        } else {
            out.append(std::to_string(value));
        }
    }
    return out;
}

// The drive only answers on a line format its profile allows. Empty lists: the documents do not say.
void check_line(Section& s, const Profile& profile, const rtu::LineFormat& format) {
    const auto title = title_of(profile);
    if (!profile.bauds.empty() && std::ranges::find(profile.bauds, format.baud) == profile.bauds.end()) {
        s.fail("the bus's baud " + std::to_string(format.baud) + " is not one " + title + " lists (" +
               joined(profile.bauds) + ")");
        return;
    }
    const auto parity = parity_name(format.parity);
    if (!profile.parities.empty() && std::ranges::find(profile.parities, parity) == profile.parities.end()) {
        s.fail("the bus's parity " + in_quotes(parity) + " is not one " + title + " lists (" +
               joined(profile.parities) + ")");
        return;
    }
    if (profile.stop_bits && *profile.stop_bits != format.stop_bits) {
        s.fail("the bus's stop_bits " + std::to_string(format.stop_bits) + " is not the " +
               std::to_string(*profile.stop_bits) + " that " + title + " uses");
    }
}

// A drive while its keys are read: what their readers need beyond the drive itself.
struct DriveDraft {
    DriveConfig drive;
    ProfileCache* profiles = nullptr;
    const rtu::LineFormat* format = nullptr;  // the bus's line, checked against the profile
    std::optional<std::int64_t> address;      // checked against the profile once it is known
    // The write_block key, read by read_blocks() once the polls are: the indirect blocks are
    // checked last, when the rest of the drive is valid.
    std::string_view write_block;
};

using DriveKeys = Keys<DriveDraft>;

void read_name(Section& s, const toml::table& /*table*/, const Key<DriveDraft>& key, DriveDraft& draft) {
    if (auto name = s.string(key.name, key.need)) {
        if (!valid_name(*name)) {
            s.fail("name " + in_quotes(*name) + " is not made of a-z, 0-9, '_' and '-'");
        } else {
            fits_shm(s, key.name, *name, shm::kNameSize, "a drive name");
        }
        draft.drive.name = std::move(*name);
    }
}

void read_address(Section& s, const toml::table& /*table*/, const Key<DriveDraft>& key, DriveDraft& draft) {
    draft.address = s.integer(key.name, -kAnyInteger, kAnyInteger, key.need);
}

// The address read before, against the profile's range.
void check_address(Section& s, DriveDraft& draft) {
    if (!draft.address) {
        return;
    }
    const auto& profile = draft.drive.profile;
    // 0 is broadcast, 248-255 reserved: a profile's range never includes them.
    const std::int64_t lo = profile ? profile->address_min : 1;
    const std::int64_t hi = profile ? profile->address_max : 247;
    if (*draft.address < lo || *draft.address > hi) {
        s.fail("address " + std::to_string(*draft.address) + " is outside " + std::to_string(lo) + "-" +
               std::to_string(hi) + (profile ? " for " + title_of(*profile) : ""));
    } else {
        draft.drive.address = static_cast<std::uint8_t>(*draft.address);
    }
}

// The profile decides which addresses and line formats are valid: both are checked as soon as
// it is known.
void read_profile(Section& s, const toml::table& /*table*/, const Key<DriveDraft>& key, DriveDraft& draft) {
    auto& drive = draft.drive;
    if (const auto type = s.string(key.name, key.need);
        type && fits_shm(s, key.name, *type, shm::kProfileSize, "a snapshot's profile type")) {
        auto profile = draft.profiles->get(*type);
        if (profile) {
            drive.profile = std::move(*profile);
        } else {
            s.fail(profile.error());
        }
    }
    check_address(s, draft);
    if (drive.profile) {
        check_line(s, *drive.profile, *draft.format);
    }
}

void read_keep_alive(Section& s, const toml::table& table, const Key<DriveDraft>& key, DriveDraft& draft) {
    if (const auto* text = table.get_as<std::string>(key.name); text != nullptr && text->get() == "off") {
        draft.drive.keep_alive = std::nullopt;
        return;
    }
    draft.drive.keep_alive = duration(s, table, key.name, key.range.shortest, key.range.longest);
}

// In LeaseFallback's order.
constexpr std::array<std::string_view, 3> kFallbacks = {"hold", "stop", "freewheel"};
static_assert(in_enum_order(kFallbacks, {LeaseFallback::Hold, LeaseFallback::Stop, LeaseFallback::Freewheel}));

// The fallback needs the profile's command word for it; without "fallback", a drive whose
// profile can stop it stops, others hold.
void read_fallback(Section& s, const toml::table& /*table*/, const Key<DriveDraft>& key, DriveDraft& draft) {
    auto& drive = draft.drive;
    const ControlInfo* control = drive.profile && drive.profile->control ? &*drive.profile->control : nullptr;
    if (const auto which = choice(s, key.name, key.range.names)) {
        drive.fallback = static_cast<LeaseFallback>(*which);
        const bool stop_missing = drive.fallback == LeaseFallback::Stop && (control == nullptr || !control->stop);
        const bool coast_missing =
            drive.fallback == LeaseFallback::Freewheel && (control == nullptr || !control->freewheel);
        if (drive.profile && (stop_missing || coast_missing)) {
            const std::string name(key.range.names[*which]);
            s.fail("fallback \"" + name + "\" needs a " + name + " command word, which profile " +
                   in_quotes(drive.profile->type) + " does not define (use \"hold\")");
        }
    } else if (control != nullptr && control->stop) {
        drive.fallback = LeaseFallback::Stop;
    }
}

// The drive's own Modbus time-out, written at commissioning: the profile must name a writable
// time-out register ([safety] comm_timeout) and the value be a whole number of its counts in its
// range. Never its "off" value: drivebusd does not switch the drive's guard off.
void read_comm_timeout(Section& s, const toml::table& table, const Key<DriveDraft>& key, DriveDraft& draft) {
    auto& drive = draft.drive;
    const auto value = duration(s, table, key.name, key.range.shortest, key.range.longest);
    if (!value || !drive.profile) {
        return;
    }
    const Profile& p = *drive.profile;
    const RegisterInfo* r = p.safety ? p.find(std::string_view(p.safety->comm_timeout)) : nullptr;
    if (r == nullptr) {
        s.fail("comm_timeout is set, but profile " + in_quotes(p.type) + " names no Modbus time-out register");
        return;
    }
    if (!writable(r->access)) {
        s.fail("comm_timeout is set, but " + r->name + " of profile " + in_quotes(p.type) + " is not writable");
        return;
    }
    drive.comm_timeout = *value;
    const auto raw = master::comm_timeout_raw(drive);
    if (!raw || (p.safety->comm_timeout_off && *raw == *p.safety->comm_timeout_off)) {
        const auto ms = [&](std::int32_t n) {
            return duration_text(std::chrono::milliseconds(p.safety->milliseconds(static_cast<std::uint16_t>(n))));
        };
        s.fail("comm_timeout " + duration_text(*value) + " is not a whole number of " + r->name + "'s steps of " +
               duration_text(std::chrono::duration_cast<Duration>(
                   std::chrono::duration<double>(p.safety->comm_timeout_seconds))) +
               " between " + ms(std::max(r->min.value_or(0), p.safety->comm_timeout_off ? 1 : 0)) + " and " +
               ms(r->max.value_or(65535)));
        drive.comm_timeout.reset();
    }
}

void read_write_block(Section& /*s*/, const toml::table& /*table*/, const Key<DriveDraft>& key, DriveDraft& draft) {
    draft.write_block = key.name;
}

std::string shown_off(const Key<DriveDraft>& /*key*/) {
    return "\"off\"";
}

std::string shown_fallback(const Key<DriveDraft>& /*key*/) {
    return "\"stop\" when the profile has a stop command word, else \"hold\"";
}

constexpr Table<DriveDraft, 8> kDriveKeys = {
    DriveKeys::custom("name", "string", Need::Required, words("[a-z0-9_-]+"), read_name, nullptr,
                      "unique across all buses"),
    DriveKeys::custom("address", "integer", Need::Required, words("the profile's address_min-address_max"),
                      read_address, nullptr, "Modbus slave address, unique on the bus"),
    DriveKeys::custom("profile", "string", Need::Required, words("a profile type"), read_profile, nullptr,
                      "the drive's profile, looked up by type"),
    // Shorter would keep the line busy with keep-alives alone.
    DriveKeys::custom("keep_alive", "duration or \"off\"", Need::Optional, durations(10ms, 1h), read_keep_alive,
                      shown_off, "a request at least this often, inside the drive's own Modbus time-out"),
    DriveKeys::duration<&DriveDraft::drive, &DriveConfig::lease>(
        "lease", 100ms, 1h, "a client writing the command or reference must renew its control lease within this"),
    DriveKeys::custom("fallback", "string", Need::Optional, names(kFallbacks), read_fallback, shown_fallback,
                      "what drivebusd does when a lease runs out: nothing, stop, or freewheel"),
    DriveKeys::custom("write_block", "array of register names", Need::Optional,
                      words("the profile's write block's min_quantity-max_quantity registers"), read_write_block,
                      DriveKeys::shown<&DriveDraft::drive, &DriveConfig::write_block>,
                      "the registers the indirect write block selects, slot by slot"),
    DriveKeys::custom("comm_timeout", "duration", Need::Optional, durations(1ms, 1h), read_comm_timeout,
                      DriveKeys::shown<&DriveDraft::drive, &DriveConfig::comm_timeout>,
                      "the drive's own Modbus time-out (ATV21 F803, whole seconds 1-100), written when the drive comes "
                      "online and holds another value"),
};

}  // namespace

DriveConfig read_drive(const toml::table& table, std::size_t index, const std::string& bus,
                       const rtu::LineFormat& format, Errors& errors, ProfileCache& profiles) {
    Section s(table, bus + " " + entry_name("drive", index), errors);
    if (const auto* name = table.get_as<std::string>("name"); name != nullptr && valid_name(name->get())) {
        s.rename(bus + " drive " + in_quotes(name->get()));
    }
    allow_only(s, table, {"poll"}, kDriveKeys);
    DriveDraft draft{{}, &profiles, &format, std::nullopt, {}};
    read_keys(s, table, kDriveKeys, draft);
    auto& drive = draft.drive;
    const auto polls = s.tables("poll");
    std::set<std::string, std::less<>> names;
    std::set<std::uint16_t> polled;  // every register the snapshot carries, once
    for (std::size_t i = 0; i < polls.size(); ++i) {
        auto poll = read_poll(*polls[i], i, s.where(), drive.profile.get(), errors);
        const auto where = s.where() + " poll " + in_quotes(poll.name);
        if (!names.insert(poll.name).second) {
            errors.add(where, "name " + in_quotes(poll.name) + " is already another poll of this drive");
        }
        for (const auto& reg : poll.registers) {
            polled.insert(reg.address);
        }
        if (polled.size() > shm::kMaxSnapshotRegisters) {
            errors.add(where, "registers: the drive's poll groups read " + std::to_string(polled.size()) +
                                  " different registers, more than the " + std::to_string(shm::kMaxSnapshotRegisters) +
                                  " a snapshot in shared memory carries");
        }
        drive.polls.push_back(std::move(poll));
    }
    if (!errors.any()) {
        read_blocks(s, drive, draft.write_block);
    }
    return std::move(drive);
}

SectionReference drive_reference() {
    return described("[[bus.drive]]", kDriveKeys);
}

}  // namespace drivebus::config::detail
