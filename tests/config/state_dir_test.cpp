// SPDX-License-Identifier: Apache-2.0
// The default state_dir: /run/drivebus, or $DRIVEBUS_STATE_DIR through LoadOptions, which a
// bus's own state_dir overrides.
#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include "config/config.hpp"

namespace drivebus::config {
namespace {

// Sets (or unsets: nullptr) an environment variable for one test and restores it after.
// NOLINTBEGIN(concurrency-mt-unsafe): the tests run on one thread
class ScopedEnv {
public:
    ScopedEnv(const char* name, const char* value) : name_(name) {
        if (const char* old = std::getenv(name)) {
            old_ = old;
        }
        if (value != nullptr) {
            ::setenv(name, value, 1);
        } else {
            ::unsetenv(name);
        }
    }
    ~ScopedEnv() {
        if (old_) {
            ::setenv(name_, old_->c_str(), 1);
        } else {
            ::unsetenv(name_);
        }
    }
    ScopedEnv(const ScopedEnv&) = delete;
    ScopedEnv& operator=(const ScopedEnv&) = delete;
    ScopedEnv(ScopedEnv&&) = delete;
    ScopedEnv& operator=(ScopedEnv&&) = delete;

private:
    const char* name_;
    std::optional<std::string> old_;
};
// NOLINTEND(concurrency-mt-unsafe)

std::string two_buses(std::string_view second_extra) {
    std::string text;
    for (const auto* name : {"line1", "line2"}) {
        text += std::string("[[bus]]\nname = \"") + name + "\"\ndevice = \"/dev/tty" + name + "\"\n";
        if (std::string_view(name) == "line2") {
            text += second_extra;
        }
        text += "  [[bus.drive]]\n  name = \"pump_" + std::string(name) +
                "\"\n  address = 1\n  profile = \"atv21\"\n"
                "    [[bus.drive.poll]]\n    registers = [\"FD00\"]\n    period = \"100ms\"\n";
    }
    return text;
}

TEST(StateDir, DefaultIsRunDrivebus) {
    const auto config = parse_config(two_buses(""), "test.toml");
    ASSERT_TRUE(config) << config.error().message;
    EXPECT_EQ(config->buses.at(0).state_dir, "/run/drivebus");
    EXPECT_EQ(config->buses.at(1).state_dir, "/run/drivebus");
}

TEST(StateDir, OptionIsTheDefaultABusOverrides) {
    LoadOptions options;
    options.state_dir = "/tmp/test-state";
    const auto config = parse_config(two_buses("state_dir = \"/var/lib/own\"\n"), "test.toml", options);
    ASSERT_TRUE(config) << config.error().message;
    EXPECT_EQ(config->buses.at(0).state_dir, "/tmp/test-state");
    EXPECT_EQ(config->buses.at(1).state_dir, "/var/lib/own");
}

TEST(StateDir, FromEnvironment) {
    {
        const ScopedEnv env("DRIVEBUS_STATE_DIR", "/tmp/test-state");
        const auto dir = state_dir_from_environment();
        ASSERT_TRUE(dir) << dir.error().message;
        EXPECT_EQ(*dir, std::optional<std::filesystem::path>("/tmp/test-state"));
    }
    {
        const ScopedEnv unset("DRIVEBUS_STATE_DIR", nullptr);
        const auto dir = state_dir_from_environment();
        ASSERT_TRUE(dir);
        EXPECT_EQ(*dir, std::nullopt);
    }
    {
        const ScopedEnv empty("DRIVEBUS_STATE_DIR", "");
        const auto dir = state_dir_from_environment();
        ASSERT_TRUE(dir);
        EXPECT_EQ(*dir, std::nullopt);
    }
}

TEST(StateDir, RelativeEnvironmentIsAnError) {
    const ScopedEnv env("DRIVEBUS_STATE_DIR", "state");
    const auto dir = state_dir_from_environment();
    ASSERT_FALSE(dir);
    EXPECT_EQ(dir.error().message, "DRIVEBUS_STATE_DIR 'state' is not an absolute path");
}

}  // namespace
}  // namespace drivebus::config
