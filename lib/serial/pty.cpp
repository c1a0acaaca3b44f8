// SPDX-License-Identifier: Apache-2.0
#include "serial/pty.hpp"

#include <fcntl.h>
#include <stdlib.h>  // NOLINT(modernize-deprecated-headers): posix_openpt and friends live here
#include <termios.h>

#include <array>

namespace drivebus::serial {

std::expected<PtyPair, sys::SysError> open_pty() {
    PtyPair pair;
    auto master =
        sys::posix_call("posix_openpt", [] { return ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
    if (!master) {
        return std::unexpected(master.error());
    }
    pair.master.reset(*master);
    if (auto granted = sys::posix_call("grantpt", [&] { return ::grantpt(pair.master.get()); }); !granted) {
        return std::unexpected(granted.error());
    }
    if (auto unlocked = sys::posix_call("unlockpt", [&] { return ::unlockpt(pair.master.get()); }); !unlocked) {
        return std::unexpected(unlocked.error());
    }
    std::array<char, 128> name{};
    if (const int rc = ::ptsname_r(pair.master.get(), name.data(), name.size()); rc != 0) {
        return std::unexpected(sys::SysError{"ptsname_r", rc});
    }
    pair.slave_path = name.data();
    auto slave =
        sys::posix_call("open", [&] { return ::open(name.data(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
    if (!slave) {
        return std::unexpected(slave.error());
    }
    pair.slave.reset(*slave);
    // The slave side starts raw, so a program that opens it without setting termios (or a
    // test) does not have its bytes translated.
    termios tio{};
    if (auto got = sys::posix_call("tcgetattr", [&] { return ::tcgetattr(pair.slave.get(), &tio); }); !got) {
        return std::unexpected(got.error());
    }
    ::cfmakeraw(&tio);
    if (auto set = sys::posix_call("tcsetattr", [&] { return ::tcsetattr(pair.slave.get(), TCSANOW, &tio); }); !set) {
        return std::unexpected(set.error());
    }
    return pair;
}

}  // namespace drivebus::serial
