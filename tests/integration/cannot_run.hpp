// SPDX-License-Identifier: Apache-2.0
// A test that cannot run here (no root for the access tests, a tool scripts/setup installs not
// installed): skipped on a developer's machine, a failure in CI (CI=true), where scripts/setup
// has installed everything and the suite runs as root, so that a suite that could not test
// something never reads as passed.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string_view>

namespace drivebus::test {

[[nodiscard]] inline bool in_ci() {
    const char* ci = std::getenv("CI");
    return ci != nullptr && std::string_view(ci) == "true";
}

}  // namespace drivebus::test

// Used as GTEST_SKIP() is: CANNOT_RUN() << "needs root ...";
#define CANNOT_RUN()                                                                                                  \
    return GTEST_MESSAGE_AT_(                                                                                         \
        __FILE__, __LINE__, ::drivebus::test::in_ci() ? "CI=true, where every test must run: cannot run" : "Skipped", \
        ::drivebus::test::in_ci() ? ::testing::TestPartResult::kFatalFailure : ::testing::TestPartResult::kSkip)
