// SPDX-License-Identifier: Apache-2.0
// What the fuzz targets share: the shipped profiles, loaded once, and a check that stops the run
// with a message when a property fails (libFuzzer then saves the input as a crash).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>

#include "drivebus/profile.hpp"

namespace drivebus::fuzz {

[[noreturn]] inline void fail(std::string_view what) {
    std::fprintf(stderr, "property failed: %.*s\n", static_cast<int>(what.size()), what.data());
    std::abort();
}

inline void check(bool ok, std::string_view what) {
    if (!ok) {
        fail(what);
    }
}

// profiles/<type>.toml of the source tree (DRIVEBUS_FUZZ_PROFILE_DIR): a target that cannot
// load it stops at once rather than fuzzing nothing.
inline std::shared_ptr<const Profile> shipped_profile(std::string_view type) {
    auto loaded = load_profile(std::string(DRIVEBUS_FUZZ_PROFILE_DIR) + "/" + std::string(type) + ".toml");
    if (!loaded) {
        fail(loaded.error().message);
    }
    return std::make_shared<const Profile>(std::move(*loaded));
}

// One error line as drivebusd logs it: not empty, no line break inside.
inline void check_one_line(std::string_view message, std::string_view what) {
    check(!message.empty() && message.find_first_of("\r\n") == std::string_view::npos, what);
}

}  // namespace drivebus::fuzz
