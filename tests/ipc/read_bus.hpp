// SPDX-License-Identifier: Apache-2.0
// A configuration's text read as the ipc core's tests need it: its first bus, with the shipped
// profiles. A text that does not read fails the test, and an empty bus stands for it.
#pragma once

#include <gtest/gtest.h>

#include <string_view>

#include "bus_toml.hpp"
#include "config/config.hpp"

namespace drivebus::test {

inline config::BusConfig read_bus(std::string_view toml) {
    config::LoadOptions options;
    options.profile_dir = DRIVEBUS_TEST_PROFILE_DIR;
    auto c = config::parse_config(toml, "test.toml", options);
    if (!c) {
        ADD_FAILURE() << c.error().message;
        return {};
    }
    return c->buses.at(0);
}

}  // namespace drivebus::test
