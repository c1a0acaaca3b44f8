// SPDX-License-Identifier: Apache-2.0
// Names, durations, choices and the profile cache shared by the configuration's readers.
#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <limits>
#include <system_error>

#include "read.hpp"

namespace drivebus::config::detail {
namespace {

namespace fs = std::filesystem;

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

std::string title_of(const Profile& profile) {
    return profile.title.empty() ? profile.type : profile.title;
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
