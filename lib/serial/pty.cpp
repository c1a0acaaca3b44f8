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
    if (::grantpt(pair.master.get()) != 0) {
        return std::unexpected(sys::SysError{"grantpt", errno});
    }
    if (::unlockpt(pair.master.get()) != 0) {
        return std::unexpected(sys::SysError{"unlockpt", errno});
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
    if (::tcgetattr(pair.slave.get(), &tio) == 0) {
        ::cfmakeraw(&tio);
        ::tcsetattr(pair.slave.get(), TCSANOW, &tio);
    }
    return pair;
}

}  // namespace drivebus::serial
