// SPDX-License-Identifier: Apache-2.0
// Profiles from files: by path, or by type name along the search path.
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <system_error>

#include "drivebus/profile.hpp"
#include "parse_sections.hpp"

#ifndef DRIVEBUS_SOURCE_PROFILE_DIR
#error "DRIVEBUS_SOURCE_PROFILE_DIR must be defined by the build"
#endif
#ifndef DRIVEBUS_SITE_PROFILE_DIR
#error "DRIVEBUS_SITE_PROFILE_DIR must be defined by the build"
#endif
#ifndef DRIVEBUS_INSTALLED_PROFILE_DIR
#error "DRIVEBUS_INSTALLED_PROFILE_DIR must be defined by the build"
#endif

namespace drivebus {
namespace {

namespace fs = std::filesystem;

constexpr std::uintmax_t kMaxFileSize = 1U << 20;  // the ATV21's profile is about 40 KiB

std::unexpected<ProfileError> fail(std::string message) {
    return std::unexpected(ProfileError{std::move(message)});
}

}  // namespace

std::expected<Profile, ProfileError> load_profile(const fs::path& file) {
    auto text = profile_detail::read_small_file(file, kMaxFileSize, "a profile");
    if (!text) {
        return fail(text.error());
    }
    return parse_profile(*text, file.string());
}

std::vector<fs::path> profile_search_path() {
    std::vector<fs::path> dirs;
    // NOLINTNEXTLINE(concurrency-mt-unsafe): read once per load; nothing here sets the environment
    if (const char* dir = std::getenv("DRIVEBUS_PROFILE_DIR"); dir != nullptr && *dir != '\0') {
        dirs.emplace_back(dir);
    }
    dirs.emplace_back(DRIVEBUS_SOURCE_PROFILE_DIR);
    // The site's profiles: one place that drivebusd, its clients and a user's shell all read,
    // so that a name, unit or scale means the same to each of them.
    dirs.emplace_back(DRIVEBUS_SITE_PROFILE_DIR);
    dirs.emplace_back(DRIVEBUS_INSTALLED_PROFILE_DIR);
    return dirs;
}

std::expected<Profile, ProfileError> load_profile_by_type(std::string_view type) {
    // The type becomes a file name: no separators, no "..", nothing to escape.
    if (!profile_detail::valid_type_name(type)) {
        return fail("profile type " + profile_detail::in_quotes(type) + " is not made of a-z, 0-9, '_' and '-'");
    }
    const std::string file = std::string(type) + ".toml";
    std::string looked;
    for (const auto& dir : profile_search_path()) {
        const auto path = dir / file;
        std::error_code ec;
        if (fs::is_regular_file(path, ec)) {
            auto profile = load_profile(path);
            if (profile && profile->type != type) {
                return fail(path.string() + ": drive.type is " + profile_detail::in_quotes(profile->type) +
                            ", not the file's name " + profile_detail::in_quotes(type));
            }
            return profile;
        }
        looked += (looked.empty() ? "" : ", ") + dir.string();
    }
    return fail("no profile " + profile_detail::in_quotes(type) + ": " + file + " is in none of " + looked);
}

}  // namespace drivebus
