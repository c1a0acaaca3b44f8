// SPDX-License-Identifier: Apache-2.0
// The serial port a bus owns: opened non-blocking and exclusively, raw, with parity and
// framing errors marked for the framer, tuned for low latency where the driver allows.
#pragma once

#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rtu/timing.hpp"
#include "sys/posix.hpp"

namespace drivebus::serial {

struct PortOptions {
    std::filesystem::path device;
    rtu::LineFormat format;
    // /run/lock-style lock file directory for the UUCP lock (LCK..ttyUSB0); empty: flock() on
    // the device only.
    std::filesystem::path lock_dir;
};

struct PortError {
    std::string message;  // one line naming the device and what failed: "/dev/ttyUSB0: busy: locked by pid 1234"
    int error = 0;        // errno, 0 if none
    // True when the device is missing or went away (ENOENT, ENODEV, ENXIO, EIO): the bus
    // retries opening with back-off instead of giving up.
    [[nodiscard]] bool device_gone() const noexcept;
};

// Why a read failed. A tty whose device went away (an unplugged USB adapter, vhangup()) keeps
// answering read() with 0 bytes, which a raw line with VMIN = 0 also returns when nothing has
// arrived: the poll state tells the two apart, and a hang-up becomes this error, never 0 bytes.
struct ReadError {
    sys::SysError sys;     // the failed call ({"read", EIO} for a hang-up, as the tty's write() says)
    bool hung_up = false;  // read() returned 0 and the tty reports POLLHUP
    [[nodiscard]] std::string message() const;
};

// The ioctl seam the port's optional features go through, so that tests can fake a UART.
class UartControl {
public:
    virtual ~UartControl() = default;
    // TIOCSERGETLSR: true when the transmitter is empty (shift register included); nullopt
    // when the driver does not support it.
    [[nodiscard]] virtual std::optional<bool> transmitter_empty(int fd) = 0;
    // RTS line (TIOCMBIS / TIOCMBIC).
    virtual std::expected<void, sys::SysError> set_rts(int fd, bool on) = 0;
};

// The real ioctls.
[[nodiscard]] std::unique_ptr<UartControl> kernel_uart_control();

class Port {
public:
    // Opens, takes the line exclusively (TIOCEXCL and a lock, so that a second drivebusd or
    // another program cannot share it), sets raw termios with INPCK|PARMRK and applies
    // low-latency tuning (ASYNC_LOW_LATENCY, FTDI latency_timer = 1 ms, 8250 rx_trig_bytes
    // = 1) where offered.
    [[nodiscard]] static std::expected<Port, PortError> open(const PortOptions& options);

    Port(Port&&) noexcept = default;
    // Closes (and unlocks) what this port held first.
    Port& operator=(Port&& other) noexcept;
    Port(const Port&) = delete;
    Port& operator=(const Port&) = delete;
    ~Port();

    [[nodiscard]] int fd() const noexcept { return fd_.get(); }
    [[nodiscard]] const std::filesystem::path& device() const noexcept { return device_; }
    // What tuning was applied or not, one line each, for the log.
    [[nodiscard]] const std::vector<std::string>& tuning() const noexcept { return tuning_; }

    // Non-blocking write and read; EINTR retried, EAGAIN (or nothing to read) reported as 0
    // bytes; a hang-up is an error (ReadError::hung_up).
    [[nodiscard]] std::expected<std::size_t, sys::SysError> write(std::span<const std::uint8_t> bytes) noexcept;
    [[nodiscard]] std::expected<std::size_t, ReadError> read(std::span<std::uint8_t> buffer) noexcept;
    // Drops anything unread or unsent (tcflush), e.g. after reopening.
    void flush() noexcept;
    // Bytes received and waiting to be read (TIOCINQ); 0 when the driver cannot tell.
    [[nodiscard]] std::size_t input_waiting() const noexcept;

private:
    Port() = default;
    void close() noexcept;
    [[nodiscard]] bool hung_up() const noexcept;
    sys::UniqueFd fd_;
    std::filesystem::path device_;
    std::filesystem::path lock_file_;  // removed on close when we made it
    std::vector<std::string> tuning_;
};

}  // namespace drivebus::serial
