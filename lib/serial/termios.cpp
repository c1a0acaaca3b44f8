// SPDX-License-Identifier: Apache-2.0
#include "serial/termios.hpp"

#include <termios.h>
#include <unistd.h>

#include <array>
#include <string_view>
#include <utility>

namespace drivebus::serial {
namespace {

constexpr std::array<std::pair<std::uint32_t, speed_t>, 19> kSpeeds{{
    {50, B50},         {75, B75},         {110, B110},       {134, B134},         {150, B150},
    {300, B300},       {600, B600},       {1200, B1200},     {2400, B2400},       {4800, B4800},
    {9600, B9600},     {19200, B19200},   {38400, B38400},   {57600, B57600},     {115200, B115200},
    {230400, B230400}, {460800, B460800}, {921600, B921600}, {1000000, B1000000},
}};

std::optional<speed_t> speed_of(std::uint32_t baud) {
    for (const auto& [rate, constant] : kSpeeds) {
        if (rate == baud) {
            return constant;
        }
    }
    return std::nullopt;
}

tcflag_t data_bits_flag(std::uint8_t bits) {
    switch (bits) {
    case 5: return CS5;
    case 6: return CS6;
    case 7: return CS7;
    default: return CS8;
    }
}

bool is_pty(int fd) {
    std::array<char, 64> name{};
    return ::ttyname_r(fd, name.data(), name.size()) == 0 && std::string_view(name.data()).starts_with("/dev/pts/");
}

}  // namespace

bool standard_baud(std::uint32_t baud) noexcept {
    return speed_of(baud).has_value();
}

std::string describe(const rtu::LineFormat& format) {
    const char parity = format.parity == rtu::Parity::None ? 'N' : (format.parity == rtu::Parity::Even ? 'E' : 'O');
    return std::to_string(format.baud) + " " + std::to_string(format.data_bits) + parity +
           std::to_string(format.stop_bits);
}

std::expected<void, sys::SysError> configure_line(int fd, const rtu::LineFormat& format, ErrorMarking marking) {
    const auto speed = speed_of(format.baud);
    if (!speed) {
        return std::unexpected(sys::SysError{"cfsetspeed", EINVAL});
    }
    termios tio{};
    if (auto got = sys::posix_call("tcgetattr", [&] { return ::tcgetattr(fd, &tio); }); !got) {
        return std::unexpected(got.error());
    }
    ::cfmakeraw(&tio);
    tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
    tio.c_cflag |= data_bits_flag(format.data_bits) | CREAD | CLOCAL;
    if (format.parity != rtu::Parity::None) {
        tio.c_cflag |= PARENB;
        if (format.parity == rtu::Parity::Odd) {
            tio.c_cflag |= PARODD;
        }
    }
    if (format.stop_bits == 2) {
        tio.c_cflag |= CSTOPB;
    }
    tio.c_iflag &= ~static_cast<tcflag_t>(IGNPAR | PARMRK | INPCK | ISTRIP | IXON | IXOFF | IXANY | IGNBRK | BRKINT);
    if (marking == ErrorMarking::Parmrk) {
        tio.c_iflag |= INPCK | PARMRK;
    }
    // Non-blocking reads return what is there; the event loop decides when to read.
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (::cfsetispeed(&tio, *speed) != 0 || ::cfsetospeed(&tio, *speed) != 0) {
        return std::unexpected(sys::SysError{"cfsetspeed", errno});
    }
    auto set = sys::posix_call("tcsetattr", [&] { return ::tcsetattr(fd, TCSANOW, &tio); });
    if (!set && set.error().error == EINVAL && (tio.c_cflag & PARENB) != 0 && is_pty(fd)) {
        // A pseudo-terminal carries bytes, not bits, and this kernel refuses PARENB on one.
        // The format still sets the timing (the character is 11 bits long on the real line).
        tio.c_cflag &= ~static_cast<tcflag_t>(PARENB | PARODD);
        tio.c_iflag &= ~static_cast<tcflag_t>(INPCK);
        set = sys::posix_call("tcsetattr", [&] { return ::tcsetattr(fd, TCSANOW, &tio); });
    }
    if (!set) {
        return std::unexpected(set.error());
    }
    return {};
}

}  // namespace drivebus::serial
