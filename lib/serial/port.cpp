// SPDX-License-Identifier: Apache-2.0
#include "serial/port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>  // NOLINT(modernize-deprecated-headers): kill()
#include <sys/file.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <utility>

#include "serial/termios.hpp"
#include "serial/tuning.hpp"

namespace drivebus::serial {
namespace {

PortError port_error(const std::filesystem::path& device, const std::string& what, int error) {
    return PortError{device.string() + ": " + what, error};
}

PortError sys_error(const std::filesystem::path& device, const sys::SysError& error) {
    return port_error(device, error.message(), error.error);
}

PortError busy(const std::filesystem::path& device, std::string detail) {
    return port_error(device, "busy (" + std::move(detail) + ")", EBUSY);
}

// The pid in a UUCP lock file: ASCII, possibly padded ("      1234\n"); 0 when unreadable.
pid_t lock_owner(const std::filesystem::path& lock) {
    auto fd = sys::posix_call("open", [&] { return ::open(lock.c_str(), O_RDONLY | O_CLOEXEC); });
    if (!fd) {
        return 0;
    }
    const sys::UniqueFd file(*fd);
    std::array<char, 32> text{};
    auto got = sys::posix_call("read", [&] { return ::read(file.get(), text.data(), text.size()); });
    if (!got) {
        return 0;
    }
    const char* first = text.data();
    const char* last = text.data() + *got;
    while (first != last && *first == ' ') {
        ++first;
    }
    pid_t pid = 0;
    std::from_chars(first, last, pid);
    return pid > 0 ? pid : 0;
}

// HDB UUCP format: the pid right-aligned in ten characters, then a newline.
std::string uucp_pid(pid_t pid) {
    auto text = std::to_string(pid);
    return std::string(text.size() < 10 ? 10 - text.size() : 0, ' ') + text + "\n";
}

bool alive(pid_t pid) {
    // EPERM: the process exists but belongs to someone else.
    return ::kill(pid, 0) == 0 || errno == EPERM;
}

// The UUCP convention (FHS /var/lock, /run/lock): LCK..<tty> holding the owner's pid as ten
// characters and a newline. Taken before the device is opened, because opening a tty can
// raise RTS and DTR under the program that holds it. Written to a temporary file and linked
// into place so that nobody reads a half-written pid. flock() on the device stays the real
// exclusion between drivebusd instances; this lock is for the other programs (minicom,
// picocom, ModemManager) that look for it.
std::expected<std::filesystem::path, PortError> take_uucp_lock(const std::filesystem::path& device,
                                                               const std::filesystem::path& dir) {
    auto name = tty_name(device);
    std::ranges::replace(name, '/', '_');
    auto lock = dir / ("LCK.." + name);
    const auto temp = dir / ("LTMP." + std::to_string(::getpid()));
    const auto content = uucp_pid(::getpid());

    ::unlink(temp.c_str());
    auto fd =
        sys::posix_call("open", [&] { return ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644); });
    if (!fd) {
        return std::unexpected(
            port_error(device, "cannot create a lock file in " + dir.string() + ": " + std::strerror(fd.error().error),
                       fd.error().error));
    }
    {
        const sys::UniqueFd file(*fd);
        auto put = sys::posix_call("write", [&] { return ::write(file.get(), content.data(), content.size()); });
        if (!put) {
            ::unlink(temp.c_str());
            return std::unexpected(sys_error(device, put.error()));
        }
    }
    // Two rounds: a stale lock is removed once; if it is back, someone else is racing us.
    for (int round = 0; round < 2; ++round) {
        if (::link(temp.c_str(), lock.c_str()) == 0) {
            ::unlink(temp.c_str());
            return lock;
        }
        const int error = errno;
        if (error != EEXIST) {
            ::unlink(temp.c_str());
            return std::unexpected(
                port_error(device, "lock file " + lock.string() + ": " + std::strerror(error), error));
        }
        const pid_t owner = lock_owner(lock);
        if (owner > 0 && alive(owner)) {
            ::unlink(temp.c_str());
            return std::unexpected(busy(device, "locked by pid " + std::to_string(owner) + " in " + lock.string()));
        }
        ::unlink(lock.c_str());  // stale: its owner is gone (or it holds no pid)
    }
    ::unlink(temp.c_str());
    return std::unexpected(busy(device, "lock file " + lock.string() + " keeps coming back"));
}

void drop_uucp_lock(const std::filesystem::path& lock) {
    // Only our own: a lock that was taken over after we lost it is someone else's.
    if (lock_owner(lock) == ::getpid()) {
        ::unlink(lock.c_str());
    }
}

class KernelUartControl final : public UartControl {
public:
    std::optional<bool> transmitter_empty(int fd) override {
        int lsr = 0;
        if (!sys::posix_call("TIOCSERGETLSR", [&] { return ::ioctl(fd, TIOCSERGETLSR, &lsr); })) {
            // ENOTTY, EINVAL, ENOIOCTLCMD: the driver cannot tell. Anything else (EIO on an
            // unplugged adapter) cannot tell either; the read side reports the loss.
            return std::nullopt;
        }
        return (static_cast<unsigned>(lsr) & TIOCSER_TEMT) != 0;
    }

    std::expected<void, sys::SysError> set_rts(int fd, bool on) override {
        int bits = TIOCM_RTS;
        const unsigned long request = on ? TIOCMBIS : TIOCMBIC;
        auto done = sys::posix_call(on ? "TIOCMBIS" : "TIOCMBIC", [&] { return ::ioctl(fd, request, &bits); });
        if (!done) {
            return std::unexpected(done.error());
        }
        return {};
    }
};

}  // namespace

bool PortError::device_gone() const noexcept {
    return error == ENOENT || error == ENODEV || error == ENXIO || error == EIO;
}

std::unique_ptr<UartControl> kernel_uart_control() {
    return std::make_unique<KernelUartControl>();
}

std::expected<Port, PortError> Port::open(const PortOptions& options) {
    const auto& device = options.device;
    if (!standard_baud(options.format.baud)) {
        return std::unexpected(port_error(
            device, std::to_string(options.format.baud) + " bit/s is not a baud rate termios can set", EINVAL));
    }

    // Removes the UUCP lock on every failure below; handed to the Port on success.
    struct LockGuard {
        std::filesystem::path path;
        LockGuard() = default;
        LockGuard(const LockGuard&) = delete;
        LockGuard& operator=(const LockGuard&) = delete;
        LockGuard(LockGuard&&) = delete;
        LockGuard& operator=(LockGuard&&) = delete;
        ~LockGuard() {
            if (!path.empty()) {
                drop_uucp_lock(path);
            }
        }
    } lock;
    if (!options.lock_dir.empty()) {
        auto taken = take_uucp_lock(device, options.lock_dir);
        if (!taken) {
            return std::unexpected(taken.error());
        }
        lock.path = *taken;
    }

    Port port;
    port.device_ = device;

    auto fd =
        sys::posix_call("open", [&] { return ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
    if (!fd) {
        if (fd.error().error == EBUSY) {  // TIOCEXCL of another program, for non-root
            return std::unexpected(busy(device, "another program holds it"));
        }
        return std::unexpected(port_error(device, std::strerror(fd.error().error), fd.error().error));
    }
    port.fd_.reset(*fd);

    // TIOCEXCL does not stop root, so a second drivebusd (running as root) is kept out by flock.
    if (auto locked = sys::posix_call("flock", [&] { return ::flock(port.fd(), LOCK_EX | LOCK_NB); }); !locked) {
        if (locked.error().error == EWOULDBLOCK) {
            return std::unexpected(busy(device, "another program holds it"));
        }
        return std::unexpected(sys_error(device, locked.error()));
    }
    if (auto excl = sys::posix_call("TIOCEXCL", [&] { return ::ioctl(port.fd(), TIOCEXCL); }); !excl) {
        if (excl.error().error == ENOTTY) {
            return std::unexpected(
                port_error(device, "not a terminal (TIOCEXCL: Inappropriate ioctl for device)", ENOTTY));
        }
        return std::unexpected(sys_error(device, excl.error()));
    }
    if (auto line = configure_line(port.fd(), options.format, ErrorMarking::Parmrk); !line) {
        return std::unexpected(sys_error(device, line.error()));
    }
    port.tuning_ = apply_low_latency(port.fd(), tty_name(device));
    // Whatever arrived before we owned the line is not ours to frame.
    port.flush();
    port.lock_file_ = std::exchange(lock.path, {});
    return port;
}

Port::~Port() {
    close();
}

Port& Port::operator=(Port&& other) noexcept {
    if (this != &other) {
        close();
        fd_ = std::move(other.fd_);
        device_ = std::move(other.device_);
        lock_file_ = std::exchange(other.lock_file_, {});
        tuning_ = std::move(other.tuning_);
    }
    return *this;
}

void Port::close() noexcept {
    if (!fd_.valid()) {
        return;  // moved from
    }
    // Exclusive mode outlives our descriptor while another one (e.g. a pty's holder) stays open.
    ::ioctl(fd_.get(), TIOCNXCL);
    fd_.reset();
    if (!lock_file_.empty()) {
        drop_uucp_lock(std::exchange(lock_file_, {}));
    }
}

std::expected<std::size_t, sys::SysError> Port::write(std::span<const std::uint8_t> bytes) noexcept {
    auto put = sys::posix_call("write", [&] { return ::write(fd_.get(), bytes.data(), bytes.size()); });
    if (!put) {
        if (put.error().error == EAGAIN) {
            return 0U;
        }
        return std::unexpected(put.error());
    }
    return static_cast<std::size_t>(*put);
}

std::expected<std::size_t, ReadError> Port::read(std::span<std::uint8_t> buffer) noexcept {
    auto got = sys::posix_call("read", [&] { return ::read(fd_.get(), buffer.data(), buffer.size()); });
    if (!got) {
        if (got.error().error == EAGAIN) {
            return 0U;
        }
        return std::unexpected(ReadError{got.error()});
    }
    if (*got == 0 && !buffer.empty() && hung_up()) {
        return std::unexpected(ReadError{sys::SysError{"read", EIO}, true});
    }
    return static_cast<std::size_t>(*got);
}

// Asked only after a read of 0 bytes (nothing there, or hung up), not on every character.
bool Port::hung_up() const noexcept {
    pollfd p{fd_.get(), POLLIN, 0};
    return sys::posix_call("poll", [&] { return ::poll(&p, 1, 0); }).value_or(0) > 0 &&
           (p.revents & (POLLHUP | POLLERR)) != 0;
}

std::string ReadError::message() const {
    return hung_up ? "hung up (the device went away)" : sys.message();
}

void Port::flush() noexcept {
    ::tcflush(fd_.get(), TCIOFLUSH);
}

std::size_t Port::input_waiting() const noexcept {
    int n = 0;
    const auto asked = sys::posix_call("ioctl(TIOCINQ)", [&] { return ::ioctl(fd_.get(), TIOCINQ, &n); });
    return asked && n > 0 ? static_cast<std::size_t>(n) : 0U;
}

}  // namespace drivebus::serial
