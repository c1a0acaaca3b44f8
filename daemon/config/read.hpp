// SPDX-License-Identifier: Apache-2.0
// Readers of the configuration's tables, on top of the profile loader's strict TOML access
// (profile/toml_reader.hpp): same one-line errors, same unknown-key check. Internal to daemon/config/.
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
#include "profile/toml_reader.hpp"

namespace drivebus::config::detail {

using profile_detail::Errors;
using profile_detail::hex4;
using profile_detail::in_quotes;
using profile_detail::Need;
using profile_detail::Section;

// Bus, drive and poll names: [a-z0-9_-]+ (they name services and appear in logs).
[[nodiscard]] bool valid_name(std::string_view name) noexcept;
// Whether `text`, the value of `key`, fits a NUL-terminated field of `field_size` bytes of the
// shared-memory payloads (drivebus/shm.hpp), which `field` names in the error. A longer text
// would be cut there and then match nothing a client asks for.
bool fits_shm(Section& s, std::string_view key, std::string_view text, std::size_t field_size, std::string_view field);
// "bus #2": an entry of an array of tables before its name is known, counting from 1.
[[nodiscard]] std::string entry_name(std::string_view array, std::size_t index);
// "none, even, odd".
[[nodiscard]] std::string listed(std::span<const std::string_view> names);

// How errors name a drive type: "Altivar 58", or its type when the profile has no title.
[[nodiscard]] std::string title_of(const Profile& profile);

// "100ms", "1s", "1500us": the largest unit that keeps the number whole.
[[nodiscard]] std::string duration_text(Duration duration);

// Checks a duration written as `text` under `key` against lo..hi.
std::optional<Duration> checked_duration(Section& s, std::string_view key, std::string_view text, Duration lo,
                                         Duration hi);
// Reads a duration key of `table` (a string such as "100ms") and checks it against lo..hi.
std::optional<Duration> duration(Section& s, const toml::table& table, std::string_view key, Duration lo, Duration hi,
                                 Need need = Need::Optional);
// Reads a string key that must be one of `names`; its index in `names`.
std::optional<std::size_t> choice(Section& s, std::string_view key, std::span<const std::string_view> names);

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
