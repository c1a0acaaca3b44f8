// SPDX-License-Identifier: Apache-2.0
#include "serial/tuning.hpp"

#include <fcntl.h>
#include <linux/serial.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <expected>
#include <optional>
#include <system_error>

#include "sys/posix.hpp"

namespace drivebus::serial {
namespace {

std::string errno_text(int error) {
    return std::strerror(error);
}

// A sysfs attribute's value without the trailing newline.
std::expected<std::string, int> read_attribute(const std::filesystem::path& path) {
    auto fd = sys::posix_call("open", [&] { return ::open(path.c_str(), O_RDONLY | O_CLOEXEC); });
    if (!fd) {
        return std::unexpected(fd.error().error);
    }
    const sys::UniqueFd file(*fd);
    std::array<char, 64> buffer{};
    auto got = sys::posix_call("read", [&] { return ::read(file.get(), buffer.data(), buffer.size() - 1); });
    if (!got) {
        return std::unexpected(got.error().error);
    }
    std::string value(buffer.data(), static_cast<std::size_t>(*got));
    while (!value.empty() && (value.back() == '\n' || value.back() == ' ')) {
        value.pop_back();
    }
    return value;
}

// One write(), as sysfs wants: the store callback sees the whole value or fails.
std::expected<void, int> write_attribute(const std::filesystem::path& path, std::string_view value) {
    auto fd = sys::posix_call("open", [&] { return ::open(path.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC); });
    if (!fd) {
        return std::unexpected(fd.error().error);
    }
    const sys::UniqueFd file(*fd);
    auto put = sys::posix_call("write", [&] { return ::write(file.get(), value.data(), value.size()); });
    if (!put) {
        return std::unexpected(put.error().error);
    }
    return {};
}

std::string low_latency_flag(int fd) {
    serial_struct info{};
    if (::ioctl(fd, TIOCGSERIAL, &info) != 0) {
        return "ASYNC_LOW_LATENCY: not offered by the driver (TIOCGSERIAL: " + errno_text(errno) + ")";
    }
    constexpr auto kFlag = static_cast<int>(ASYNC_LOW_LATENCY);
    if ((info.flags & kFlag) != 0) {
        return "ASYNC_LOW_LATENCY already set";
    }
    info.flags |= kFlag;
    if (::ioctl(fd, TIOCSSERIAL, &info) != 0) {
        return "ASYNC_LOW_LATENCY: not set (TIOCSSERIAL: " + errno_text(errno) + ")";
    }
    serial_struct check{};
    if (::ioctl(fd, TIOCGSERIAL, &check) == 0 && (check.flags & kFlag) == 0) {
        return "ASYNC_LOW_LATENCY: the driver ignored it";
    }
    return "ASYNC_LOW_LATENCY set";
}

std::optional<std::filesystem::path> existing(std::initializer_list<std::filesystem::path> candidates) {
    for (const auto& path : candidates) {
        std::error_code ec;
        if (std::filesystem::exists(path, ec)) {
            return path;
        }
    }
    return std::nullopt;
}

std::string latency_timer(const std::filesystem::path& tty_dir) {
    // ftdi_sio puts it on the usb-serial port device; "device/.." is resolved by the kernel
    // after following the symlink, which is what some kernels' layouts need.
    const auto path = existing({tty_dir / "device" / "latency_timer", tty_dir / "device" / ".." / "latency_timer"});
    if (!path) {
        return "latency_timer: not an FTDI adapter";
    }
    const auto before = read_attribute(*path);
    if (!before) {
        return "latency_timer: unreadable (" + errno_text(before.error()) + ")";
    }
    if (*before == "1") {
        return "latency_timer: already 1 ms";
    }
    if (::access(path->c_str(), W_OK) != 0) {
        return "latency_timer: " + *before + " ms, not writable (" + errno_text(errno) +
               "); a udev rule can set it to 1";
    }
    if (auto put = write_attribute(*path, "1\n"); !put) {
        return "latency_timer: " + *before + " ms, setting 1 failed (" + errno_text(put.error()) + ")";
    }
    const auto after = read_attribute(*path);
    return "latency_timer: " + *before + " -> " + after.value_or("?") + " ms";
}

std::string rx_trigger(const std::filesystem::path& tty_dir) {
    const auto path = tty_dir / "rx_trig_bytes";
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
        return "rx_trig_bytes: not an 8250 UART with a FIFO";
    }
    const auto before = read_attribute(path);
    if (!before) {
        // EINVAL: an 8250 whose FIFO cannot be tuned (no FIFO, or DMA).
        return "rx_trig_bytes: not adjustable (" + errno_text(before.error()) + ")";
    }
    // The driver takes the nearest level at or below the value, so 1 selects the lowest.
    if (auto put = write_attribute(path, "1\n"); !put) {
        return "rx_trig_bytes: " + *before + ", setting the lowest level failed (" + errno_text(put.error()) + ")";
    }
    const auto after = read_attribute(path).value_or("?");
    if (after == *before) {
        return "rx_trig_bytes: " + after + " (the lowest level)";
    }
    return "rx_trig_bytes: " + *before + " -> " + after;
}

}  // namespace

std::string tty_name(const std::filesystem::path& device) {
    std::error_code ec;
    auto real = std::filesystem::canonical(device, ec);
    if (ec) {
        real = device;
    }
    const auto relative = real.lexically_relative("/dev");
    if (!relative.empty() && *relative.begin() != "..") {
        return relative.string();
    }
    return real.filename().string();
}

std::vector<std::string> apply_low_latency(int fd, std::string_view name, const std::filesystem::path& sysfs_tty) {
    const auto tty_dir = sysfs_tty / name;
    return {low_latency_flag(fd), latency_timer(tty_dir), rx_trigger(tty_dir)};
}

}  // namespace drivebus::serial
