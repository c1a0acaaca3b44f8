// SPDX-License-Identifier: Apache-2.0
// Test helper: an error message is one line that starts with the file name and holds every one
// of `parts`.
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>
#include <string_view>

namespace drivebus::test {

inline ::testing::AssertionResult one_line_error(const std::string& message, std::string_view file,
                                                 std::initializer_list<std::string_view> parts) {
    if (!message.starts_with(std::string(file) + ": ")) {
        return ::testing::AssertionFailure() << "does not start with the file name: " << message;
    }
    if (message.find('\n') != std::string::npos) {
        return ::testing::AssertionFailure() << "more than one line: " << message;
    }
    for (const auto part : parts) {
        if (message.find(part) == std::string::npos) {
            return ::testing::AssertionFailure() << "'" << part << "' missing from: " << message;
        }
    }
    return ::testing::AssertionSuccess() << message;
}

}  // namespace drivebus::test
