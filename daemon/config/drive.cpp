// One [[bus.drive]]: its profile, its address and line checked against that profile, its polls.
#include <algorithm>
#include <limits>
#include <set>

#include "drivebus/shm.hpp"
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

std::optional<Duration> read_keep_alive(Section& s, const toml::table& table) {
    if (const auto* text = table.get_as<std::string>("keep_alive"); text != nullptr && text->get() == "off") {
        return std::nullopt;
    }
    // Shorter would keep the line busy with keep-alives alone.
    return duration(s, table, "keep_alive", 10ms, 1h);
}

// The fallback needs the profile's command word for it; without "fallback", a drive whose
// profile can stop it stops, others hold.
void read_lease(Section& s, const toml::table& table, DriveConfig& drive) {
    drive.lease = duration(s, table, "lease", 100ms, 1h).value_or(drive.lease);
    const ControlInfo* control = drive.profile && drive.profile->control ? &*drive.profile->control : nullptr;
    static constexpr std::array<std::string_view, 3> kNames = {"hold", "stop", "freewheel"};
    if (const auto which = choice(s, "fallback", kNames)) {
        drive.fallback = static_cast<LeaseFallback>(*which);
        const bool stop_missing = drive.fallback == LeaseFallback::Stop && (control == nullptr || !control->stop);
        const bool coast_missing =
            drive.fallback == LeaseFallback::Freewheel && (control == nullptr || !control->freewheel);
        if (drive.profile && (stop_missing || coast_missing)) {
            s.fail("fallback \"" + std::string(kNames.at(*which)) + "\" needs a " + std::string(kNames.at(*which)) +
                   " command word, which profile " + in_quotes(drive.profile->type) +
                   " does not define (use \"hold\")");
        }
    } else if (control != nullptr && control->stop) {
        drive.fallback = LeaseFallback::Stop;
    }
}

}  // namespace

DriveConfig read_drive(const toml::table& table, std::size_t index, const std::string& bus,
                       const rtu::LineFormat& format, Errors& errors, ProfileCache& profiles) {
    Section s(table, bus + " " + entry_name("drive", index), errors);
    if (const auto* name = table.get_as<std::string>("name"); name != nullptr && valid_name(name->get())) {
        s.rename(bus + " drive " + in_quotes(name->get()));
    }
    s.allow_only({"name", "address", "profile", "keep_alive", "lease", "fallback", "poll", "write_block"});
    DriveConfig drive;
    if (auto name = s.string("name", Need::Required)) {
        if (!valid_name(*name)) {
            s.fail("name " + in_quotes(*name) + " is not made of a-z, 0-9, '_' and '-'");
        } else {
            fits_shm(s, "name", *name, shm::kNameSize, "a drive name");
        }
        drive.name = std::move(*name);
    }
    const auto address = s.integer("address", -kAnyInteger, kAnyInteger, Need::Required);
    if (const auto type = s.string("profile", Need::Required);
        type && fits_shm(s, "profile", *type, shm::kProfileSize, "a snapshot's profile type")) {
        auto profile = profiles.get(*type);
        if (profile) {
            drive.profile = std::move(*profile);
        } else {
            s.fail(profile.error());
        }
    }
    if (address) {
        // 0 is broadcast, 248-255 reserved: a profile's range never includes them.
        const std::int64_t lo = drive.profile ? drive.profile->address_min : 1;
        const std::int64_t hi = drive.profile ? drive.profile->address_max : 247;
        if (*address < lo || *address > hi) {
            s.fail("address " + std::to_string(*address) + " is outside " + std::to_string(lo) + "-" +
                   std::to_string(hi) + (drive.profile ? " for " + title_of(*drive.profile) : ""));
        } else {
            drive.address = static_cast<std::uint8_t>(*address);
        }
    }
    if (drive.profile) {
        check_line(s, *drive.profile, format);
    }
    drive.keep_alive = read_keep_alive(s, table);
    read_lease(s, table, drive);
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
        read_blocks(s, drive);
    }
    return drive;
}

}  // namespace drivebus::config::detail
