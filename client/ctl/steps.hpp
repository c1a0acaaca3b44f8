// SPDX-License-Identifier: Apache-2.0
// What drivebusctl's commands share (commands.cpp, scan.cpp): an error made on the spot, a
// failed step that carries its exit status out of the command, the bus connected or the
// command ended.
#pragma once

#include <cstdint>
#include <expected>
#include <functional>
#include <string>
#include <string_view>

#include "commands.hpp"
#include "drivebus/client.hpp"

namespace drivebus::ctl {

inline constexpr Milliseconds kFirstData{1000};  // how long to wait for a first status or snapshot

[[nodiscard]] Error error_of(ErrorKind kind, std::string message);

// A failed step: the exit status once reported.
struct Failed {
    int status;
};

// The value, or the error reported and the command ended (Failed).
template <typename T>
T need(std::expected<T, Error> result, const Options& options, const std::string& context = {}) {
    if (!result) {
        throw Failed{report(options, result.error(), context)};
    }
    return std::move(*result);
}

[[nodiscard]] Bus connect(const Options& options);
// A response that is no result, as an error.
[[nodiscard]] Error response_error(const shm::Response& r);
// Fails with the error, the drive's profile adding what it knows of the request.
[[noreturn]] void fail_request(const Options& options, Error error, const Drive& drive, std::string_view what,
                               std::uint16_t start, std::size_t count, const std::string& context);
// Runs a command's body: its exit status, or a failed step's.
int guarded(const std::function<int()>& body);

}  // namespace drivebus::ctl
