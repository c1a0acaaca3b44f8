// SPDX-License-Identifier: Apache-2.0
// The board stage's guest: the /init of an initramfs booted by Debian's arm64 kernel in
// qemu-system-aarch64 -M virt (tests/board/run). It mounts what a test needs, runs the
// GoogleTest cases below on the kernel's real drivers, prints their results on the console
// (hvc0, a file on the host) and powers the guest off.
//
// The PL011 (/dev/ttyAMA0, the amba-pl011 driver) is wired by qemu to a host pty where
// drivebus-sim plays an Altivar 21 at the address and with the register value that
// /board.conf names. Under TCG the UART is not the wire: these cases check what the driver
// accepts, keeps and reports, and that bytes cross it both ways, not timing.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/serial.h>
#include <sys/ioctl.h>
#include <sys/mount.h>
#include <sys/reboot.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rtu/codec.hpp"
#include "rtu/parmrk.hpp"
#include "serial/direction.hpp"
#include "serial/port.hpp"

namespace {

using namespace drivebus;
using namespace std::chrono_literals;

// What the host put in /board.conf ("key = value" lines).
struct Board {
    std::string line = "/dev/ttyAMA0";
    rtu::SlaveAddress drive = 1;
    std::uint16_t reg = 0;
    std::uint16_t value = 0;
    std::uint16_t write_value = 0;
};
Board board;

std::map<std::string, std::string> read_conf(const char* path) {
    std::map<std::string, std::string> out;
    std::ifstream in(path);
    std::string text;
    while (std::getline(in, text)) {
        const auto eq = text.find('=');
        if (eq == std::string::npos) {
            continue;
        }
        auto trim = [](std::string s) {
            s.erase(0, s.find_first_not_of(" \t"));
            s.erase(s.find_last_not_of(" \t\r") + 1);
            return s;
        };
        out[trim(text.substr(0, eq))] = trim(text.substr(eq + 1));
    }
    return out;
}

std::uint16_t word(const std::map<std::string, std::string>& conf, const std::string& key) {
    const auto it = conf.find(key);
    if (it == conf.end()) {
        std::fprintf(stderr, "board.conf: no '%s'\n", key.c_str());
        return 0;
    }
    return static_cast<std::uint16_t>(std::stoul(it->second, nullptr, 0));
}

serial::PortOptions line_options() {
    serial::PortOptions options;
    options.device = board.line;
    options.format = rtu::LineFormat{.baud = 19200, .data_bits = 8, .parity = rtu::Parity::Even, .stop_bits = 1};
    return options;
}

serial_rs485 rs485_of(int fd) {
    serial_rs485 conf{};
    EXPECT_EQ(::ioctl(fd, TIOCGRS485, &conf), 0) << std::strerror(errno);
    return conf;
}

// One request and its reply over the port, as the master does it: PARMRK undone, the reply's
// length known from the request, a deadline in place of the master's time-out.
std::expected<rtu::ResponseAdu, std::string> transact(serial::Port& port, const rtu::RequestAdu& request) {
    auto frame = rtu::encode_request(request);
    if (!frame) {
        return std::unexpected("encode_request failed");
    }
    auto written = port.write(frame->bytes());
    if (!written || *written != frame->size()) {
        return std::unexpected("write to the line failed");
    }
    rtu::ParmrkDecoder parmrk;
    std::vector<std::uint8_t> reply;
    std::array<std::uint8_t, 256> raw{};
    std::array<rtu::RxChar, 257> chars{};
    // Generous: TCG, a pty hop, and a host that may be busy with another stage.
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (std::chrono::steady_clock::now() < deadline) {
        const auto needed = rtu::reply_bytes_needed(request, reply);
        if (needed == 0) {
            return std::unexpected("a reply that cannot answer this request: " + std::to_string(reply.size()) +
                                   " byte(s)");
        }
        if (reply.size() >= needed) {
            auto decoded = rtu::decode_response(request, reply);
            if (!decoded) {
                return std::unexpected("the reply does not decode");
            }
            return *decoded;
        }
        auto got = port.read(raw);
        if (!got) {
            return std::unexpected("read: " + got.error().message());
        }
        if (*got == 0) {
            std::this_thread::sleep_for(2ms);
            continue;
        }
        const auto n = parmrk.decode(std::span(raw.data(), *got), chars);
        for (std::size_t i = 0; i < n; ++i) {
            if (chars[i].error) {
                return std::unexpected("a character with a parity or framing error");
            }
            reply.push_back(chars[i].value);
        }
    }
    return std::unexpected("no complete reply within 20 s (" + std::to_string(reply.size()) + " byte(s))");
}

// The line as drivebusd opens it: 19200 8E1, raw, parity errors marked for the framer.
TEST(Pl011, OpensWithTheLinesSettings) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    termios tio{};
    ASSERT_EQ(::tcgetattr(port->fd(), &tio), 0);
    EXPECT_EQ(::cfgetospeed(&tio), B19200);
    EXPECT_EQ(::cfgetispeed(&tio), B19200);
    EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
    EXPECT_NE(tio.c_cflag & PARENB, 0U);
    EXPECT_EQ(tio.c_cflag & PARODD, 0U);
    EXPECT_EQ(tio.c_cflag & CSTOPB, 0U);
    EXPECT_NE(tio.c_iflag & INPCK, 0U);
    EXPECT_NE(tio.c_iflag & PARMRK, 0U);
    EXPECT_EQ(tio.c_lflag & ICANON, 0U);
    for (const auto& line : port->tuning()) {
        std::printf("tuning: %s\n", line.c_str());
    }
    // A second opener is refused: drivebusd holds the line alone.
    auto second = serial::Port::open(line_options());
    EXPECT_FALSE(second);
}

// direction = "kernel" with drivebusd's defaults: the PL011 keeps what was asked.
TEST(Pl011, KeepsTheKernelDirectionAsAsked) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    auto direction = serial::make_kernel_direction(port->fd(), serial::KernelRs485Options{});
    ASSERT_TRUE(direction) << direction.error().message;
    EXPECT_EQ((*direction)->name(), "kernel");
    const auto conf = rs485_of(port->fd());
    std::printf("TIOCGRS485: flags 0x%x, delay_rts_before_send %u, delay_rts_after_send %u\n", conf.flags,
                conf.delay_rts_before_send, conf.delay_rts_after_send);
    EXPECT_NE(conf.flags & SER_RS485_ENABLED, 0U);
    EXPECT_NE(conf.flags & SER_RS485_RTS_ON_SEND, 0U);
    EXPECT_EQ(conf.flags & SER_RS485_RTS_AFTER_SEND, 0U);
    EXPECT_EQ(conf.flags & SER_RS485_RX_DURING_TX, 0U);
    EXPECT_EQ(conf.delay_rts_before_send, 0U);
    EXPECT_EQ(conf.delay_rts_after_send, 0U);
}

// A delay beyond what the serial core allows (100 ms) is clamped by the kernel without an
// error; drivebusd reads it back and refuses in one line naming what changed.
TEST(Pl011, ADelayTheKernelClampsIsRefused) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    serial::KernelRs485Options options;
    options.delay_after_send_ms = 1000;
    auto direction = serial::make_kernel_direction(port->fd(), options);
    ASSERT_FALSE(direction) << "the PL011 kept a 1000 ms delay";
    const auto kept = rs485_of(port->fd());
    std::printf("refused: %s\n", direction.error().message.c_str());
    EXPECT_TRUE(direction.error().permanent);
    EXPECT_NE(kept.delay_rts_after_send, 1000U);
    EXPECT_NE(direction.error().message.find("delay_rts_after_send 1000 -> " +
                                             std::to_string(kept.delay_rts_after_send) + " ms"),
              std::string::npos)
        << direction.error().message;
}

// RTS at the same level during and after sending cannot switch a transceiver: the kernel
// changes it to RTS on send only, and drivebusd refuses what it did not ask for.
TEST(Pl011, EqualRtsLevelsAreRefused) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    serial::KernelRs485Options options;
    options.rts_on_send = true;
    options.rts_after_send = true;
    auto direction = serial::make_kernel_direction(port->fd(), options);
    ASSERT_FALSE(direction) << "the PL011 kept RTS high both during and after sending";
    std::printf("refused: %s\n", direction.error().message.c_str());
    EXPECT_TRUE(direction.error().permanent);
    EXPECT_NE(direction.error().message.find("the driver changed the RS485 settings"), std::string::npos)
        << direction.error().message;
}

// TIOCSERGETLSR, by which the bus loop knows the transmitter is empty.
TEST(Pl011, ReportsAnEmptyTransmitter) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    auto uart = serial::kernel_uart_control();
    ASSERT_EQ(::tcdrain(port->fd()), 0) << std::strerror(errno);
    const auto empty = uart->transmitter_empty(port->fd());
    ASSERT_TRUE(empty.has_value()) << "TIOCSERGETLSR not supported";
    EXPECT_TRUE(*empty);
}

// Bytes cross the PL011 both ways: a read of the simulated drive's register gets the value
// the host set, with kernel direction on.
TEST(Pl011, ReadsTheSimulatedDrive) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    auto direction = serial::make_kernel_direction(port->fd(), serial::KernelRs485Options{});
    ASSERT_TRUE(direction) << direction.error().message;
    const rtu::RequestAdu read{board.drive, rtu::ReadHoldingRegisters{board.reg, 1}};
    auto reply = transact(*port, read);
    ASSERT_TRUE(reply) << reply.error();
    const auto* values = std::get_if<rtu::ReadHoldingRegistersResponse>(&reply->pdu);
    ASSERT_NE(values, nullptr) << "not a read reply (an exception?)";
    ASSERT_EQ(values->values.size(), 1U);
    EXPECT_EQ(values->values[0], board.value);
}

// A write reaches the simulator: its echo, then a read that returns the new value.
TEST(Pl011, AWriteReachesTheSimulatedDrive) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    auto direction = serial::make_kernel_direction(port->fd(), serial::KernelRs485Options{});
    ASSERT_TRUE(direction) << direction.error().message;
    const rtu::RequestAdu write{board.drive, rtu::WriteSingleRegister{board.reg, board.write_value}};
    auto echo = transact(*port, write);
    ASSERT_TRUE(echo) << echo.error();
    const auto* written = std::get_if<rtu::WriteSingleRegisterResponse>(&echo->pdu);
    ASSERT_NE(written, nullptr) << "not a write echo (an exception?)";
    EXPECT_EQ(written->value, board.write_value);
    auto reply = transact(*port, rtu::RequestAdu{board.drive, rtu::ReadHoldingRegisters{board.reg, 1}});
    ASSERT_TRUE(reply) << reply.error();
    const auto* values = std::get_if<rtu::ReadHoldingRegistersResponse>(&reply->pdu);
    ASSERT_NE(values, nullptr);
    ASSERT_EQ(values->values.size(), 1U);
    EXPECT_EQ(values->values[0], board.write_value);
}

// PID 1's duties before the tests: the file systems they need, and the console as stdio.
void become_init() {
    ::mkdir("/proc", 0555);
    ::mkdir("/sys", 0555);
    ::mkdir("/dev", 0755);
    ::mkdir("/tmp", 01777);
    ::mount("proc", "/proc", "proc", 0, nullptr);
    ::mount("sysfs", "/sys", "sysfs", 0, nullptr);
    ::mount("devtmpfs", "/dev", "devtmpfs", 0, nullptr);
    ::mount("tmpfs", "/tmp", "tmpfs", 0, nullptr);
    const int console = ::open("/dev/hvc0", O_RDWR | O_NOCTTY);
    if (console >= 0) {
        ::dup2(console, 1);
        ::dup2(console, 2);
        if (console > 2) {
            ::close(console);
        }
    }
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
}

}  // namespace

int main(int argc, char** argv) {
    const bool init = ::getpid() == 1;
    if (init) {
        become_init();
    }
    const auto conf = read_conf(argc > 1 ? argv[1] : "/board.conf");
    if (auto it = conf.find("line"); it != conf.end()) {
        board.line = it->second;
    }
    board.drive = static_cast<rtu::SlaveAddress>(word(conf, "drive"));
    board.reg = word(conf, "register");
    board.value = word(conf, "value");
    board.write_value = word(conf, "write_value");
    ::testing::InitGoogleTest(&argc, argv);
    GTEST_FLAG_SET(color, "no");  // the console is a tty; the host reads plain lines
    const int failed = RUN_ALL_TESTS();
    // The host reads this line: without it the guest did not finish.
    std::printf("board-guest: done, exit %d\n", failed);
    std::fflush(stdout);
    if (!init) {
        return failed;
    }
    ::sync();
    ::reboot(RB_POWER_OFF);
    for (;;) {
        ::pause();  // PID 1 must not return
    }
}
