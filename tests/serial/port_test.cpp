// SPDX-License-Identifier: Apache-2.0
// The serial port on a pty pair (how every test line runs): exclusive open, raw termios
// with PARMRK, the UUCP lock, error messages, and the low-latency tuning on a fake sysfs.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "serial/port.hpp"
#include "serial/pty.hpp"
#include "serial/tuning.hpp"

namespace drivebus::serial {
namespace {

namespace fs = std::filesystem;

// A directory of its own, removed with everything in it.
class TempDir {
public:
    TempDir() {
        std::string pattern = (fs::temp_directory_path() / "drivebus-serial-XXXXXX").string();
        if (::mkdtemp(pattern.data()) == nullptr) {
            throw std::runtime_error("mkdtemp failed");
        }
        path_ = pattern;
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    [[nodiscard]] const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

std::string read_file(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

void write_file(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
}

// Waits (bounded, for an event, not a fixed time) until `fd` is readable.
bool readable(int fd) {
    pollfd p{fd, POLLIN, 0};
    return ::poll(&p, 1, 2000) == 1 && (p.revents & POLLIN) != 0;
}

std::vector<std::uint8_t> read_some(int fd) {
    std::array<std::uint8_t, 64> buffer{};
    const auto got = ::read(fd, buffer.data(), buffer.size());
    return got > 0 ? std::vector<std::uint8_t>(buffer.begin(), buffer.begin() + got) : std::vector<std::uint8_t>{};
}

// The lock file's content for `pid`: ten characters, right-aligned, and a newline.
std::string uucp(pid_t pid) {
    std::array<char, 16> text{};
    (void)std::snprintf(text.data(), text.size(), "%10d\n", static_cast<int>(pid));
    return text.data();
}

// A pid that has just exited, so a lock file naming it is stale.
pid_t dead_pid() {
    const pid_t child = ::fork();
    if (child == 0) {
        ::_exit(0);
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    return child;
}

class PortTest : public ::testing::Test {
protected:
    void SetUp() override {
        auto opened = open_pty();
        ASSERT_TRUE(opened.has_value()) << opened.error().message();
        pty = std::move(*opened);
        options.device = pty.slave_path;
        // 8N1: a pty drops PARENB, and glibc then refuses to set the same parity a second time.
        options.format = {19200, 8, rtu::Parity::None, 1};
    }
    [[nodiscard]] fs::path lock_file(const fs::path& dir) const {
        return dir / ("LCK..pts_" + pty.slave_path.filename().string());
    }

    PtyPair pty;
    PortOptions options;
};

TEST_F(PortTest, OpensRawWithErrorMarkingAndSaysWhatItTuned) {
    auto port = Port::open(options);
    ASSERT_TRUE(port.has_value()) << port.error().message;
    EXPECT_EQ(port->device(), pty.slave_path);
    termios tio{};
    ASSERT_EQ(::tcgetattr(port->fd(), &tio), 0);
    EXPECT_EQ(tio.c_iflag & (INPCK | PARMRK), INPCK | PARMRK);
    EXPECT_EQ(tio.c_lflag & ICANON, 0U);
    EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
    EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B19200));
    // A pty offers none of the tuning: each is a note, none an error.
    ASSERT_EQ(port->tuning().size(), 3U);
    EXPECT_TRUE(port->tuning()[0].starts_with("ASYNC_LOW_LATENCY: not offered by the driver (TIOCGSERIAL: "))
        << port->tuning()[0];
    EXPECT_EQ(port->tuning()[1], "latency_timer: not an FTDI adapter");
    EXPECT_EQ(port->tuning()[2], "rx_trig_bytes: not an 8250 UART with a FIFO");
}

TEST_F(PortTest, WritesAndReadsNonBlocking) {
    auto port = Port::open(options);
    ASSERT_TRUE(port.has_value()) << port.error().message;
    std::array<std::uint8_t, 64> buffer{};
    auto nothing = port->read(buffer);
    ASSERT_TRUE(nothing.has_value()) << nothing.error().message();
    EXPECT_EQ(*nothing, 0U) << "EAGAIN is 0 bytes";

    const std::vector<std::uint8_t> request{0x01, 0x03, 0xFD, 0x00, 0x00, 0x01, 0xB5, 0xA6};
    auto put = port->write(request);
    ASSERT_TRUE(put.has_value()) << put.error().message();
    EXPECT_EQ(*put, request.size());
    ASSERT_TRUE(readable(pty.master.get()));
    EXPECT_EQ(read_some(pty.master.get()), request);

    // PARMRK is on: a data 0xFF arrives doubled, as the framer expects.
    const std::array<std::uint8_t, 2> reply{0x01, 0xFF};
    ASSERT_EQ(::write(pty.master.get(), reply.data(), reply.size()), 2);
    ASSERT_TRUE(readable(port->fd()));
    auto got = port->read(buffer);
    ASSERT_TRUE(got.has_value()) << got.error().message();
    EXPECT_EQ(std::vector<std::uint8_t>(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(*got)),
              (std::vector<std::uint8_t>{0x01, 0xFF, 0xFF}));
}

// An unplugged USB adapter hangs its tty up, and read() then returns 0 bytes for ever: that is
// an error the bus acts on, never "nothing yet", which a raw line with VMIN = 0 also returns.
TEST_F(PortTest, AHangUpIsAnErrorNotZeroBytes) {
    auto port = Port::open(options);
    ASSERT_TRUE(port.has_value()) << port.error().message;
    std::array<std::uint8_t, 64> buffer{};
    auto nothing = port->read(buffer);
    ASSERT_TRUE(nothing.has_value()) << nothing.error().message();
    EXPECT_EQ(*nothing, 0U);
    if (::ioctl(pty.slave.get(), TIOCVHANGUP) != 0) {
        GTEST_SKIP() << "TIOCVHANGUP needs CAP_SYS_ADMIN: " << std::strerror(errno);
    }
    auto gone = port->read(buffer);
    ASSERT_FALSE(gone.has_value()) << "a hang-up read as " << *gone << " bytes";
    EXPECT_TRUE(gone.error().hung_up);
    EXPECT_EQ(gone.error().sys.error, EIO);
    EXPECT_EQ(gone.error().message(), "hung up (the device went away)");
}

TEST_F(PortTest, ASecondOpenIsBusy) {
    auto first = Port::open(options);
    ASSERT_TRUE(first.has_value()) << first.error().message;
    const auto second = Port::open(options);
    ASSERT_FALSE(second.has_value());
    EXPECT_EQ(second.error().message, pty.slave_path.string() + ": busy (another program holds it)");
    EXPECT_EQ(second.error().error, EBUSY);
    EXPECT_FALSE(second.error().device_gone());
}

TEST_F(PortTest, ClosingReleasesTheLine) {
    {
        auto first = Port::open(options);
        ASSERT_TRUE(first.has_value()) << first.error().message;
    }
    auto again = Port::open(options);
    EXPECT_TRUE(again.has_value()) << again.error().message;
}

TEST_F(PortTest, MovingKeepsTheLineAndAssigningClosesTheOldOne) {
    auto other_pty = open_pty();
    ASSERT_TRUE(other_pty.has_value());
    const TempDir locks;
    options.lock_dir = locks.path();
    auto a = Port::open(options);
    ASSERT_TRUE(a.has_value()) << a.error().message;
    PortOptions other = options;
    other.device = other_pty->slave_path;
    auto b = Port::open(other);
    ASSERT_TRUE(b.has_value()) << b.error().message;

    Port moved = std::move(*a);
    EXPECT_TRUE(fs::exists(lock_file(locks.path())));
    EXPECT_FALSE(Port::open(PortOptions{options.device, options.format, {}}).has_value());
    moved = std::move(*b);  // closes and unlocks the first line
    EXPECT_FALSE(fs::exists(lock_file(locks.path())));
    EXPECT_TRUE(Port::open(options).has_value());
    EXPECT_EQ(moved.device(), other_pty->slave_path);
    EXPECT_TRUE(fs::exists(locks.path() / ("LCK..pts_" + other_pty->slave_path.filename().string())));
}

TEST_F(PortTest, TheUucpLockHoldsOurPidAndGoesWithThePort) {
    const TempDir locks;
    options.lock_dir = locks.path();
    {
        auto port = Port::open(options);
        ASSERT_TRUE(port.has_value()) << port.error().message;
        EXPECT_EQ(read_file(lock_file(locks.path())), uucp(::getpid()));
        const auto second = Port::open(options);
        ASSERT_FALSE(second.has_value());
        EXPECT_EQ(second.error().message, pty.slave_path.string() + ": busy (locked by pid " +
                                              std::to_string(::getpid()) + " in " + lock_file(locks.path()).string() +
                                              ")");
        // The refused open left the holder's lock alone.
        EXPECT_TRUE(fs::exists(lock_file(locks.path())));
    }
    EXPECT_FALSE(fs::exists(lock_file(locks.path())));
    EXPECT_TRUE(fs::is_empty(locks.path())) << "temporary files left behind";
}

TEST_F(PortTest, AStaleLockIsTakenOver) {
    const TempDir locks;
    options.lock_dir = locks.path();
    write_file(lock_file(locks.path()), uucp(dead_pid()));
    auto port = Port::open(options);
    ASSERT_TRUE(port.has_value()) << port.error().message;
    EXPECT_EQ(read_file(lock_file(locks.path())), uucp(::getpid()));
}

TEST_F(PortTest, ALiveOwnersLockIsRespected) {
    const TempDir locks;
    options.lock_dir = locks.path();
    const pid_t owner = ::getppid();  // alive: it is waiting for us
    write_file(lock_file(locks.path()), std::to_string(owner) + "\n");
    const auto port = Port::open(options);
    ASSERT_FALSE(port.has_value());
    EXPECT_EQ(port.error().message, pty.slave_path.string() + ": busy (locked by pid " + std::to_string(owner) +
                                        " in " + lock_file(locks.path()).string() + ")");
    EXPECT_EQ(read_file(lock_file(locks.path())), std::to_string(owner) + "\n");
}

TEST(PortErrorTest, AMissingDeviceIsGoneAndLeavesNoLock) {
    const TempDir locks;
    const auto port = Port::open(PortOptions{"/dev/ttyDRIVEBUS-none", {}, locks.path()});
    ASSERT_FALSE(port.has_value());
    EXPECT_EQ(port.error().message, "/dev/ttyDRIVEBUS-none: No such file or directory");
    EXPECT_EQ(port.error().error, ENOENT);
    EXPECT_TRUE(port.error().device_gone());
    EXPECT_TRUE(fs::is_empty(locks.path()));
}

TEST(PortErrorTest, DeviceGoneIsOnlyTheDisappearingErrors) {
    for (const int e : {ENOENT, ENODEV, ENXIO, EIO}) {
        EXPECT_TRUE((PortError{"", e}.device_gone())) << e;
    }
    for (const int e : {0, EBUSY, EACCES, ENOTTY, EINVAL}) {
        EXPECT_FALSE((PortError{"", e}.device_gone())) << e;
    }
}

TEST(PortErrorTest, NotATerminal) {
    const auto port = Port::open(PortOptions{"/dev/null", {}, {}});
    ASSERT_FALSE(port.has_value());
    EXPECT_EQ(port.error().message, "/dev/null: not a terminal (TIOCEXCL: Inappropriate ioctl for device)");
    EXPECT_FALSE(port.error().device_gone());
}

TEST(PortErrorTest, ABaudRateTermiosCannotSet) {
    const auto port = Port::open(PortOptions{"/dev/ttyS0", {12345, 8, rtu::Parity::None, 1}, {}});
    ASSERT_FALSE(port.has_value());
    EXPECT_EQ(port.error().message, "/dev/ttyS0: 12345 bit/s is not a baud rate termios can set");
}

TEST(UartControlTest, APtyCannotTellWhenItsTransmitterIsEmptyNorSetRts) {
    auto pty = open_pty();
    ASSERT_TRUE(pty.has_value());
    const auto uart = kernel_uart_control();
    EXPECT_EQ(uart->transmitter_empty(pty->slave.get()), std::nullopt);
    const auto rts = uart->set_rts(pty->slave.get(), true);
    ASSERT_FALSE(rts.has_value());
    EXPECT_EQ(rts.error().message(), "TIOCMBIS: Inappropriate ioctl for device");
}

TEST(TtyNameTest, NamesAsTheKernelDoes) {
    EXPECT_EQ(tty_name("/dev/ttyDRIVEBUS-none"), "ttyDRIVEBUS-none");
    auto pty = open_pty();
    ASSERT_TRUE(pty.has_value());
    const TempDir dir;
    fs::create_symlink(pty->slave_path, dir.path() / "by-id-link");
    EXPECT_EQ(tty_name(dir.path() / "by-id-link"), "pts/" + pty->slave_path.filename().string());
}

class TuningTest : public ::testing::Test {
protected:
    void SetUp() override {
        auto opened = open_pty();
        ASSERT_TRUE(opened.has_value());
        pty = std::move(*opened);
    }
    PtyPair pty;
    TempDir sysfs;
};

TEST_F(TuningTest, FtdiLatencyTimerIsSetToOneMillisecond) {
    const auto timer = sysfs.path() / "ttyUSB0" / "device" / "latency_timer";
    write_file(timer, "16\n");
    const auto notes = apply_low_latency(pty.slave.get(), "ttyUSB0", sysfs.path());
    ASSERT_EQ(notes.size(), 3U);
    EXPECT_EQ(notes[1], "latency_timer: 16 -> 1 ms");
    EXPECT_EQ(read_file(timer), "1\n");
    EXPECT_EQ(notes[2], "rx_trig_bytes: not an 8250 UART with a FIFO");
}

TEST_F(TuningTest, FtdiLatencyTimerOneLevelUpAndAlreadySet) {
    fs::create_directories(sysfs.path() / "ttyUSB1" / "device");
    write_file(sysfs.path() / "ttyUSB1" / "latency_timer", "1\n");
    const auto notes = apply_low_latency(pty.slave.get(), "ttyUSB1", sysfs.path());
    EXPECT_EQ(notes.at(1), "latency_timer: already 1 ms");
}

TEST_F(TuningTest, Uart8250RxTriggerIsSetToTheLowestLevel) {
    const auto trigger = sysfs.path() / "ttyS1" / "rx_trig_bytes";
    write_file(trigger, "8\n");
    const auto notes = apply_low_latency(pty.slave.get(), "ttyS1", sysfs.path());
    EXPECT_EQ(notes.at(1), "latency_timer: not an FTDI adapter");
    EXPECT_EQ(notes.at(2), "rx_trig_bytes: 8 -> 1");
    EXPECT_EQ(read_file(trigger), "1\n");
}

}  // namespace
}  // namespace drivebus::serial
