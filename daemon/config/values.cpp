// SPDX-License-Identifier: Apache-2.0
// Names, durations, choices and the profile cache shared by the configuration's readers.
#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <limits>
#include <system_error>

#include "duration/duration.hpp"
#include "read.hpp"

namespace drivebus::config::detail {
namespace {

namespace fs = std::filesystem;

struct Unit {
    std::string_view suffix;
    std::int64_t nanoseconds;
};

// Largest first, for duration_text().
constexpr std::array<Unit, 4> kUnits = {{{"s", 1'000'000'000}, {"ms", 1'000'000}, {"us", 1'000}, {"ns", 1}}};

// The loader's messages name the type already: "profile: no profile 'atv99': ...".
std::string profile_error(const std::string& message) {
    return "profile: " + message;
}

}  // namespace

bool valid_name(std::string_view name) noexcept {
    return !name.empty() && std::ranges::all_of(name, [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
}

bool fits_shm(Section& s, std::string_view key, std::string_view text, std::size_t field_size, std::string_view field) {
    const auto most = field_size - 1;
    if (text.size() <= most) {
        return true;
    }
    s.fail(std::string(key) + " " + in_quotes(text) + " has " + std::to_string(text.size()) +
           " characters, more than the " + std::to_string(most) + " that " + std::string(field) +
           " in shared memory holds");
    return false;
}

std::string entry_name(std::string_view array, std::size_t index) {
    return std::string(array) + " #" + std::to_string(index + 1);
}

std::string listed(std::span<const std::string_view> names) {
    std::string out;
    for (const auto name : names) {
        out.append(out.empty() ? "" : ", ").append(name);
    }
    return out;
}

std::string title_of(const Profile& profile) {
    return profile.title.empty() ? profile.type : profile.title;
}

std::string duration_text(Duration duration) {
    const auto ns = duration.count();
    for (const auto& unit : kUnits) {
        if (ns % unit.nanoseconds == 0) {
            return std::to_string(ns / unit.nanoseconds) + std::string(unit.suffix);
        }
    }
    return std::to_string(ns) + "ns";
}

std::optional<Duration> checked_duration(Section& s, std::string_view key, std::string_view text, Duration lo,
                                         Duration hi) {
    const auto value = drivebus::parse_duration(text);
    if (!value) {
        s.fail(std::string(key) + " " + in_quotes(text) + " " + value.error());
        return std::nullopt;
    }
    if (*value < lo || *value > hi) {
        const bool below = *value < lo;
        s.fail(std::string(key) + " " + std::string(text) + (below ? " is below " : " is above ") +
               duration_text(below ? lo : hi));
        return std::nullopt;
    }
    return *value;
}

std::optional<Duration> duration(Section& s, const toml::table& table, std::string_view key, Duration lo, Duration hi,
                                 Need need) {
    // A bare number has no unit: say so rather than only "must be a string".
    if (const auto* node = table.get(key); node != nullptr && (node->is_integer() || node->is_floating_point())) {
        s.fail(std::string(key) + " must be a string with a unit, e.g. \"100ms\", not a bare number");
        return std::nullopt;
    }
    const auto text = s.string(key, need);
    if (!text) {
        return std::nullopt;
    }
    return checked_duration(s, key, *text, lo, hi);
}

std::optional<std::size_t> choice(Section& s, std::string_view key, std::span<const std::string_view> names) {
    const auto text = s.string(key);
    if (!text) {
        return std::nullopt;
    }
    const auto it = std::ranges::find(names, *text);
    if (it == names.end()) {
        s.fail(std::string(key) + " " + in_quotes(*text) + " is not one of " + listed(names));
        return std::nullopt;
    }
    return static_cast<std::size_t>(it - names.begin());
}

std::expected<std::shared_ptr<const Profile>, std::string> ProfileCache::get(const std::string& type) {
    if (const auto it = loaded_.find(type); it != loaded_.end()) {
        return it->second;
    }
    return loaded_.emplace(type, load(type)).first->second;
}

std::expected<std::shared_ptr<const Profile>, std::string> ProfileCache::load(const std::string& type) const {
    if (!dir_) {
        auto profile = load_profile_by_type(type);
        if (!profile) {
            return std::unexpected(profile_error(profile.error().message));
        }
        return std::make_shared<const Profile>(std::move(*profile));
    }
    // The type becomes a file name: nothing that could leave the directory.
    if (!valid_name(type)) {
        return std::unexpected(
            profile_error("profile type " + in_quotes(type) + " is not made of a-z, 0-9, '_' and '-'"));
    }
    const auto path = *dir_ / (type + ".toml");
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
        return std::unexpected(
            profile_error("no profile " + in_quotes(type) + ": " + type + ".toml is not in " + dir_->string()));
    }
    auto profile = load_profile(path);
    if (!profile) {
        return std::unexpected(profile_error(profile.error().message));
    }
    if (profile->type != type) {
        return std::unexpected(
            profile_error(path.string() + ": drive.type is " + in_quotes(profile->type) + ", not the file's name"));
    }
    return std::make_shared<const Profile>(std::move(*profile));
}

}  // namespace drivebus::config::detail
