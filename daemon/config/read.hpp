// SPDX-License-Identifier: Apache-2.0
// Readers of the configuration's tables, on the settings library's key tables and strict TOML
// access (settings/keys.hpp, settings/reader.hpp). Internal to daemon/config/.
#pragma once

#include <cstddef>
#include <expected>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "config/reference.hpp"
#include "settings/keys.hpp"
#include "settings/reader.hpp"

namespace drivebus::config::detail {

using settings::allow_only;
using settings::checked_duration;
using settings::choice;
using settings::described;
using settings::duration;
using settings::duration_text;
using settings::durations;
using settings::Errors;
using settings::field;
using settings::hex4;
using settings::in_enum_order;
using settings::in_quotes;
using settings::integers;
using settings::Key;
using settings::Keys;
using settings::listed;
using settings::listed_in;
using settings::names;
using settings::Need;
using settings::Range;
using settings::read_keys;
using settings::Section;
using settings::Table;
using settings::words;

// Bus, drive and poll names: [a-z0-9_-]+ (they name services and appear in logs).
[[nodiscard]] bool valid_name(std::string_view name) noexcept;
// Whether `text`, the value of `key`, fits a NUL-terminated field of `field_size` bytes of the
// shared-memory payloads (drivebus/shm.hpp), which `field` names in the error. A longer text
// would be cut there and then match nothing a client asks for.
bool fits_shm(Section& s, std::string_view key, std::string_view text, std::size_t field_size, std::string_view field);
// "bus #2": an entry of an array of tables before its name is known, counting from 1.
[[nodiscard]] std::string entry_name(std::string_view array, std::size_t index);

// How errors name a drive type: "Altivar 58", or its type when the profile has no title.
[[nodiscard]] std::string title_of(const Profile& profile);

// Profiles by type, each loaded once and shared by every drive of that type.
class ProfileCache {
public:
    explicit ProfileCache(const LoadOptions& options) : dir_(options.profile_dir) {}
    // The profile, or the loader's one-line error.
    std::expected<std::shared_ptr<const Profile>, std::string> get(const std::string& type);

private:
    std::expected<std::shared_ptr<const Profile>, std::string> load(const std::string& type) const;

    std::optional<std::filesystem::path> dir_;
    std::map<std::string, std::expected<std::shared_ptr<const Profile>, std::string>, std::less<>> loaded_;
};

// Drive names seen so far on every bus: name -> the bus that has it ("bus 'line1'").
using DriveNames = std::map<std::string, std::string, std::less<>>;

[[nodiscard]] RealtimeConfig read_realtime(const toml::table& table, Errors& errors);
[[nodiscard]] BusConfig read_bus(const toml::table& table, std::size_t index, Errors& errors, ProfileCache& profiles,
                                 DriveNames& drive_names);
// `bus` names the bus in errors; `format` is the bus's line, checked against the profile.
[[nodiscard]] DriveConfig read_drive(const toml::table& table, std::size_t index, const std::string& bus,
                                     const rtu::LineFormat& format, Errors& errors, ProfileCache& profiles);
// The indirect blocks drivebusd sets up on the drive (its indirect poll, its key `write_block`).
void read_blocks(Section& s, DriveConfig& drive, std::string_view write_block);
[[nodiscard]] PollGroup read_poll(const toml::table& table, std::size_t index, const std::string& drive,
                                  const Profile* profile, Errors& errors);

// The tables of reference(): [realtime] and [ipc]; [[bus]] and its direction's keys; [[bus.drive]];
// [[bus.drive.poll]].
[[nodiscard]] std::vector<SectionReference> top_reference();
[[nodiscard]] std::vector<SectionReference> bus_reference();
[[nodiscard]] SectionReference drive_reference();
[[nodiscard]] SectionReference poll_reference();

}  // namespace drivebus::config::detail
