// SPDX-License-Identifier: Apache-2.0
#include "ipc/lease_token.hpp"

#include <sys/random.h>

#include <cstdlib>
#include <stdexcept>

#include "log/log.hpp"
#include "sys/posix.hpp"

namespace drivebus::ipc {
namespace {

// Blocks only until the kernel's pool is first initialised, long before drivebusd serves on a
// board that has booted.
std::expected<LeaseToken, sys::SysError> draw() {
    LeaseToken token{};
    auto* bytes = reinterpret_cast<unsigned char*>(token.data());
    std::size_t got = 0;
    while (got < sizeof token) {
        const auto n = sys::posix_call("getrandom", [&] { return ::getrandom(bytes + got, sizeof token - got, 0); });
        if (!n) {
            return std::unexpected(n.error());
        }
        got += static_cast<std::size_t>(*n);
    }
    return token;
}

}  // namespace

TokenSource random_tokens() {
    if (auto first = draw(); !first) {
        throw std::runtime_error("control lease tokens need getrandom(2): " + first.error().message());
    }
    return [] {
        auto token = draw();
        if (!token) {
            log::error("control lease token: " + token.error().message() +
                       "; stopping rather than hand out a "
                       "guessable token");
            std::abort();
        }
        return *token;
    };
}

}  // namespace drivebus::ipc
