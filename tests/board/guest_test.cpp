// SPDX-License-Identifier: Apache-2.0
// The board stage's guest: the /init of an initramfs booted by Debian's arm64 kernel in
// qemu-system-aarch64 -M virt (tests/board/run). It mounts what a test needs, runs the
// GoogleTest cases below on the kernel's real drivers, prints their results on the console
// (hvc0, a file on the host) and powers the guest off.
//
// The PL011 (/dev/ttyAMA0, the amba-pl011 driver) is wired by qemu to a host pty where
// drivebus-sim plays an Altivar 21 (the pump) and an Altivar 58 (the fan) at the addresses
// and with the register values that /board.conf names. Under TCG the UART is not the wire:
// these cases check what the driver accepts, keeps and reports, and that bytes cross it both
// ways, not timing.
//
// The Pl011 cases drive the line through drivebus's line libraries, linked in; the Packaged
// cases run drivebusd and drivebusctl as the arm64 Debian packages install them (unpacked
// into the initramfs by the host with the libraries they link, from Debian 13's arm64
// packages), with drivebusd's embedded RouDi.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/gpio.h>
#include <linux/serial.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/mount.h>
#include <sys/reboot.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
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
#include <regex>
#include <sstream>
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
    // The packaged programs' case: the fan's address, a register of it and its value.
    bool packages = false;
    rtu::SlaveAddress fan = 2;
    std::string fan_register;
    std::uint16_t fan_value = 0;
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
    // An Altivar 21 and an Altivar 58 on one line: the ATV58's 8N1 (the ATV21's F801 = 0).
    options.format = rtu::LineFormat{.baud = 19200, .data_bits = 8, .parity = rtu::Parity::None, .stop_bits = 1};
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

// The line as drivebusd opens it: 19200 8N1, raw, framing errors marked for the framer.
TEST(Pl011, OpensWithTheLinesSettings) {
    auto port = serial::Port::open(line_options());
    ASSERT_TRUE(port) << port.error().message;
    termios tio{};
    ASSERT_EQ(::tcgetattr(port->fd(), &tio), 0);
    EXPECT_EQ(::cfgetospeed(&tio), B19200);
    EXPECT_EQ(::cfgetispeed(&tio), B19200);
    EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
    EXPECT_EQ(tio.c_cflag & PARENB, 0U);
    EXPECT_EQ(tio.c_cflag & CSTOPB, 0U);
    EXPECT_NE(tio.c_iflag & INPCK, 0U);
    EXPECT_NE(tio.c_iflag & PARMRK, 0U);
    EXPECT_EQ(tio.c_lflag & ICANON, 0U);
    // The low-latency tuning drivebusd logs at start, as the PL011 takes it: the flag is set,
    // and the FTDI timer and the 8250 FIFO trigger are said not to apply.
    const auto& tuning = port->tuning();
    for (const auto& line : tuning) {
        std::printf("tuning: %s\n", line.c_str());
    }
    ASSERT_EQ(tuning.size(), 3U);
    EXPECT_TRUE(tuning[0] == "ASYNC_LOW_LATENCY set" || tuning[0] == "ASYNC_LOW_LATENCY already set") << tuning[0];
    EXPECT_EQ(tuning[1], "latency_timer: not an FTDI adapter");
    EXPECT_EQ(tuning[2], "rx_trig_bytes: not an 8250 UART with a FIFO");
    serial_struct info{};
    ASSERT_EQ(::ioctl(port->fd(), TIOCGSERIAL, &info), 0) << std::strerror(errno);
    EXPECT_NE(info.flags & static_cast<int>(ASYNC_LOW_LATENCY), 0) << "the driver does not keep ASYNC_LOW_LATENCY";
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
    EXPECT_FALSE(direction.error().no_rs485_support);  // no kernel_fallback hides it
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
    EXPECT_FALSE(direction.error().no_rs485_support);
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
    // The drive as it was found, for the packaged drivebusd's case.
    auto restored = transact(*port, rtu::RequestAdu{board.drive, rtu::WriteSingleRegister{board.reg, board.value}});
    ASSERT_TRUE(restored) << restored.error();
}

// --- the packaged programs -------------------------------------------------------------------

// A program's exit status and what it printed (stdout and stderr together).
struct Ran {
    int status = -1;  // the exit code, or -1: killed, not started, or past its deadline
    std::string out;
};

std::vector<char*> c_strings(std::vector<std::string>& strings) {
    std::vector<char*> out;
    for (auto& s : strings) {
        out.push_back(s.data());
    }
    out.push_back(nullptr);
    return out;
}

std::vector<std::string> program_env(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> env = {"PATH=/usr/sbin:/usr/bin", "HOME=/root", "LC_ALL=C"};
    env.insert(env.end(), extra.begin(), extra.end());
    return env;
}

// Starts argv with its output to `log` (a file); -1 if fork failed.
pid_t spawn(std::vector<std::string> argv, const std::string& log, std::vector<std::string> env) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        const int in = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
        if (out < 0 || in < 0 || ::dup2(in, 0) < 0 || ::dup2(out, 1) < 0 || ::dup2(out, 2) < 0) {
            ::_exit(126);
        }
        auto args = c_strings(argv);
        auto envp = c_strings(env);
        ::execve(args[0], args.data(), envp.data());
        ::_exit(127);
    }
    return pid;
}

std::string slurp(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// Waits for pid to exit until the deadline: its exit code, or -1 (killed, or still running).
int wait_exit(pid_t pid, std::chrono::steady_clock::time_point deadline, bool* still_running = nullptr) {
    for (;;) {
        int status = 0;
        const pid_t done = ::waitpid(pid, &status, WNOHANG);
        if (done == pid) {
            return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        }
        if (done < 0 || std::chrono::steady_clock::now() > deadline) {
            if (still_running != nullptr) {
                *still_running = done == 0;
            }
            return -1;
        }
        std::this_thread::sleep_for(10ms);
    }
}

// Runs a program to its end (TCG is slow: a generous deadline, never reached when it works).
Ran run(std::vector<std::string> argv, std::chrono::seconds limit = 120s) {
    static int runs = 0;
    const std::string log = "/tmp/run-" + std::to_string(++runs) + ".log";
    const pid_t pid = spawn(std::move(argv), log, program_env());
    if (pid < 0) {
        return {-1, "fork failed"};
    }
    bool running = false;
    Ran ran;
    ran.status = wait_exit(pid, std::chrono::steady_clock::now() + limit, &running);
    if (running) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
    }
    ran.out = slurp(log);
    return ran;
}

// drivebusd as its unit runs it: started, and ready when it says READY=1 on NOTIFY_SOCKET.
class Daemon {
public:
    explicit Daemon(const std::string& config) {
        ::mkdir("/run", 0755);
        notify_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", kNotify);
        ::unlink(kNotify);
        if (::bind(notify_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
            std::printf("bind %s: %s\n", kNotify, std::strerror(errno));
        }
        pid_ = spawn({"/usr/sbin/drivebusd", "--config", config}, kLog,
                     program_env({std::string("NOTIFY_SOCKET=") + kNotify}));
    }
    Daemon(const Daemon&) = delete;
    Daemon& operator=(const Daemon&) = delete;
    ~Daemon() {
        if (pid_ > 0 && !reaped_) {  // never left running into the next case
            ::kill(pid_, SIGKILL);
            ::waitpid(pid_, nullptr, 0);
        }
        ::close(notify_);
    }

    // True once READY=1 came; false if drivebusd exited (exit_code()) or the deadline passed.
    bool ready(std::chrono::seconds limit) {
        const auto deadline = std::chrono::steady_clock::now() + limit;
        while (std::chrono::steady_clock::now() < deadline) {
            pollfd p{notify_, POLLIN, 0};
            if (::poll(&p, 1, 50) == 1) {
                std::array<char, 512> message{};
                const auto n = ::recv(notify_, message.data(), message.size() - 1, 0);
                if (n > 0 && std::string_view(message.data(), static_cast<std::size_t>(n)).contains("READY=1")) {
                    return true;
                }
            }
            int status = 0;
            if (::waitpid(pid_, &status, WNOHANG) == pid_) {
                reaped_ = true;
                exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
                return false;
            }
        }
        return false;
    }
    // SIGTERM, then its exit code (-1 if it did not exit within the limit).
    int stop(std::chrono::seconds limit = 60s) {
        if (!reaped_) {
            ::kill(pid_, SIGTERM);
        }
        return exit_code(limit);
    }
    // Waits for drivebusd to exit on its own: its exit code, or -1 (killed, or still running).
    int exit_code(std::chrono::seconds limit) {
        if (!reaped_) {
            bool running = false;
            const int code = wait_exit(pid_, std::chrono::steady_clock::now() + limit, &running);
            if (running) {
                return -1;
            }
            reaped_ = true;
            exit_code_ = code;
        }
        return exit_code_;
    }
    static std::string log() { return slurp(kLog); }

private:
    static constexpr const char* kNotify = "/run/drivebusd-notify";
    static constexpr const char* kLog = "/tmp/drivebusd.log";
    int notify_ = -1;
    pid_t pid_ = -1;
    bool reaped_ = false;
    int exit_code_ = -1;
};

// drivebusd's configuration for the line: the pump (ATV21) and the fan (ATV58), kernel
// direction unless `direction` says another; `extra` goes into [[bus]].
std::string write_config(const std::string& path, const std::string& extra,
                         const std::string& direction = "direction = \"kernel\"\n") {
    std::ofstream out(path);
    out << "[realtime]\n"
           "mode = \"off\"  # one emulated CPU: nothing to gain, and a FIFO thread could starve the init\n"
           "lock_memory = false\n"
           "\n[[bus]]\nname = \"line\"\ndevice = \""
        << board.line << "\"\nbaud = 19200\nparity = \"none\"\n"
        << direction << "response_timeout = \"1s\"  # TCG and a pty hop\n"
        << extra << "\n  [[bus.drive]]\n  name = \"pump\"\n  address = " << int{board.drive}
        << "\n  profile = \"atv21\"\n  [[bus.drive]]\n  name = \"fan\"\n  address = " << int{board.fan}
        << "\n  profile = \"atv58\"\n";
    return path;
}

// The raw value in `drivebusctl --json read`'s output, or -1.
long raw_of(const std::string& json) {
    std::smatch m;
    if (std::regex_search(json, m, std::regex(R"re("raw"\s*:\s*([0-9]+))re"))) {
        return std::stol(m[1]);
    }
    return -1;
}

std::size_t count_of(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) {
        ++n;
    }
    return n;
}

bool packages_in_guest() {
    return board.packages && ::access("/usr/sbin/drivebusd", X_OK) == 0 && ::access("/usr/bin/drivebusctl", X_OK) == 0;
}

TEST(Packaged, ProgramsRunFromThePackages) {
    if (!board.packages) {
        GTEST_SKIP() << "the host put no packages in this initramfs (tests/board/run --packages)";
    }
    ASSERT_TRUE(packages_in_guest()) << "no /usr/sbin/drivebusd or /usr/bin/drivebusctl";
    const auto version = run({"/usr/sbin/drivebusd", "--version"});
    std::printf("%s", version.out.c_str());
    EXPECT_EQ(version.status, 0) << version.out;
    const auto config = write_config("/tmp/check.toml", "");
    const auto check = run({"/usr/sbin/drivebusd", "--check-config", "--config", config});
    EXPECT_EQ(check.status, 0) << check.out;
}

// drivebusd on the PL011 with direction = "kernel", and drivebusctl, a libdrivebus client,
// through drivebusd's embedded RouDi: reads of both drives get the simulator's values, a
// write reaches the pump (read back from the line), and drivebusd stops cleanly.
TEST(Packaged, DrivebusdAndDrivebusctlOnThePl011) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    Daemon daemon(write_config("/tmp/drivebusd.toml", ""));
    ASSERT_TRUE(daemon.ready(180s)) << "drivebusd not ready (exit " << daemon.exit_code(0s) << "):\n" << Daemon::log();
    const auto pump =
        run({"/usr/bin/drivebusctl", "--json", "--timeout", "10s", "read", "pump", std::to_string(board.reg)});
    EXPECT_EQ(pump.status, 0) << pump.out;
    EXPECT_EQ(raw_of(pump.out), board.value) << pump.out;
    const auto fan = run({"/usr/bin/drivebusctl", "--json", "--timeout", "10s", "read", "fan", board.fan_register});
    EXPECT_EQ(fan.status, 0) << fan.out;
    EXPECT_EQ(raw_of(fan.out), board.fan_value) << fan.out;
    const auto written = run({"/usr/bin/drivebusctl", "--timeout", "10s", "write", "pump", std::to_string(board.reg),
                              std::to_string(board.write_value)});
    EXPECT_EQ(written.status, 0) << written.out;
    const auto again =
        run({"/usr/bin/drivebusctl", "--json", "--timeout", "10s", "read", "pump", std::to_string(board.reg)});
    EXPECT_EQ(raw_of(again.out), board.write_value) << again.out;
    // The drive as it was found, for the cases after this one.
    const auto restored = run({"/usr/bin/drivebusctl", "--timeout", "10s", "write", "pump", std::to_string(board.reg),
                               std::to_string(board.value)});
    EXPECT_EQ(restored.status, 0) << restored.out;
    EXPECT_EQ(daemon.stop(), 0) << Daemon::log();
    std::printf("drivebusd said:\n%s", Daemon::log().c_str());
}

// What the PL011 cannot keep (RTS high both during and after sending: the driver clears
// RTS_AFTER_SEND): drivebusd refuses at start, in one line, with exit 78 (EX_CONFIG); with a
// kernel_fallback too, which is for a driver without RS485 support, not one that changed
// what was asked.
TEST(Packaged, DrivebusdRefusesWhatTheDriverChanges) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    for (const std::string fallback : {"", "kernel_fallback = \"rts\"\n"}) {
        SCOPED_TRACE(fallback.empty() ? "no kernel_fallback" : "kernel_fallback = \"rts\"");
        Daemon daemon(write_config("/tmp/refused.toml", "rts_on_send = true\nrts_after_send = true\n" + fallback));
        EXPECT_FALSE(daemon.ready(180s)) << Daemon::log();
        EXPECT_EQ(daemon.exit_code(60s), 78) << Daemon::log();
        const auto log = Daemon::log();
        std::printf("drivebusd said:\n%s", log.c_str());
        EXPECT_EQ(count_of(log, "error:"), 1U) << log;
        EXPECT_NE(log.find("the driver changed the RS485 settings: rts_after_send 1 -> 0; ask for what the "
                           "driver keeps"),
                  std::string::npos)
            << log;
    }
}

// --- direction = "gpio" on the PL061 ---------------------------------------------------------

// The virt board's PL061 (gpiochip0, 8 lines; line 3 is the power button's). drivebusd's
// driver enable goes on a free line.
constexpr const char* kGpioChip = "/dev/gpiochip0";
constexpr unsigned kGpioLine = 4;

// The kernel's view of a line (GPIO_V2_GET_LINEINFO_IOCTL), read without libgpiod.
std::optional<gpio_v2_line_info> gpio_line_info(unsigned offset) {
    const int chip = ::open(kGpioChip, O_RDWR | O_CLOEXEC);
    if (chip < 0) {
        return std::nullopt;
    }
    gpio_v2_line_info info{};
    info.offset = offset;
    const int r = ::ioctl(chip, GPIO_V2_GET_LINEINFO_IOCTL, &info);
    ::close(chip);
    return r == 0 ? std::optional(info) : std::nullopt;
}

std::string gpio_chip_label() {
    const int chip = ::open(kGpioChip, O_RDWR | O_CLOEXEC);
    gpiochip_info info{};
    const int r = chip < 0 ? -1 : ::ioctl(chip, GPIO_GET_CHIPINFO_IOCTL, &info);
    if (chip >= 0) {
        ::close(chip);
    }
    return r == 0 ? std::string(info.label) : std::string();
}

// The line held as an output by `consumer`, as another program would hold it, until closed.
int hold_gpio_line(unsigned offset, const char* consumer) {
    const int chip = ::open(kGpioChip, O_RDWR | O_CLOEXEC);
    if (chip < 0) {
        return -1;
    }
    gpio_v2_line_request request{};
    request.offsets[0] = offset;
    request.num_lines = 1;
    request.config.flags = GPIO_V2_LINE_FLAG_OUTPUT;
    std::snprintf(request.consumer, sizeof request.consumer, "%s", consumer);
    const int r = ::ioctl(chip, GPIO_V2_GET_LINE_IOCTL, &request);
    ::close(chip);
    return r == 0 ? request.fd : -1;
}

// The kernel's own record of what drivebusd did, from tracefs: every value set on a GPIO line
// (gpio:gpio_value) and, from the same threads, each write() and TIOCSERGETLSR ioctl.
class KernelTrace {
public:
    KernelTrace() {
        ::mkdir("/sys/kernel/tracing", 0755);
        if (::mount("nodev", "/sys/kernel/tracing", "tracefs", 0, nullptr) != 0 && errno != EBUSY) {
            error_ = std::string("mount tracefs: ") + std::strerror(errno);
            return;
        }
        const bool ok = put("tracing_on", "0") && put("trace", "") && put("buffer_size_kb", "4096") &&
                        put("events/syscalls/sys_enter_ioctl/filter", "cmd == 0x5459") &&  // TIOCSERGETLSR
                        put("events/syscalls/sys_enter_write/filter", "count <= 256") &&
                        put("events/gpio/gpio_value/enable", "1") &&
                        put("events/syscalls/sys_enter_write/enable", "1") &&
                        put("events/syscalls/sys_enter_ioctl/enable", "1") && put("tracing_on", "1");
        if (!ok && error_.empty()) {
            error_ = "tracefs refused a setting";
        }
    }
    KernelTrace(const KernelTrace&) = delete;
    KernelTrace& operator=(const KernelTrace&) = delete;
    ~KernelTrace() {
        put("tracing_on", "0");
        put("events/enable", "0");
    }
    [[nodiscard]] const std::string& error() const { return error_; }
    // Stops recording; what was recorded.
    std::string take() {
        put("tracing_on", "0");
        return slurp("/sys/kernel/tracing/trace");
    }

private:
    bool put(const std::string& file, const std::string& value) {
        const auto path = "/sys/kernel/tracing/" + file;
        const int fd = ::open(path.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
        if (fd < 0) {
            error_ = path + ": " + std::strerror(errno);
            return false;
        }
        const auto n = ::write(fd, value.data(), value.size());
        ::close(fd);
        if (!value.empty() && n != static_cast<ssize_t>(value.size())) {
            error_ = path + ": " + std::strerror(errno);
            return false;
        }
        return true;
    }
    std::string error_;
};

// One event of the trace, from the thread that sent.
struct TraceEvent {
    enum Kind { Set, Write, Lsr } kind;
    int fd = -1;     // Write, Lsr
    int value = -1;  // Set: the level on the pin (active-low inverted)
};

// What the trace says of drivebusd's driver enable, checked transmission by transmission.
struct EnableRecord {
    std::size_t transmissions = 0;   // runs of writes to the line, each up to its TIOCSERGETLSR
    std::size_t windows = 0;         // enabled, written, drained, released: as drivebusd should
    std::size_t writes_outside = 0;  // bytes written to the line with the driver not enabled
    std::size_t released_early = 0;  // released after a write with no TIOCSERGETLSR between
    int last_level = -1;             // the pin's last level from the sending thread
    std::string problem;             // the first thing out of order, for the failure's message
};

// `active` is the pin level that enables the driver (0 when active low).
EnableRecord check_enable(const std::string& trace, int active) {
    // "<comm>-<tid> [cpu] flags time: gpio_value: <gpio> set <v>", "sys_write(fd: 0x5, ...)",
    // "sys_ioctl(fd: 0x5, cmd: 0x5459, ...)"; the numbers in syscall arguments are hex.
    const std::regex event(
        R"(-(\d+)\s+\[\d+\].*: (?:gpio_value: \d+ set (\d)|sys_(write|ioctl)\(fd: (?:0x)?([0-9a-f]+)))");
    std::map<int, std::vector<TraceEvent>> by_thread;
    std::istringstream lines(trace);
    std::string text;
    int port_fd = -1;
    int sender = -1;
    while (std::getline(lines, text)) {
        std::smatch m;
        if (!std::regex_search(text, m, event)) {
            continue;
        }
        const int tid = std::stoi(m[1]);
        if (m[2].matched) {
            by_thread[tid].push_back({TraceEvent::Set, -1, std::stoi(m[2])});
        } else {
            const int fd = std::stoi(m[4], nullptr, 16);
            const bool lsr = m[3] == "ioctl";
            by_thread[tid].push_back({lsr ? TraceEvent::Lsr : TraceEvent::Write, fd, -1});
            if (lsr && sender < 0) {
                sender = tid;  // the bus thread: the one that asks whether the transmitter emptied
                port_fd = fd;
            }
        }
    }
    EnableRecord record;
    if (sender < 0) {
        record.problem = "no TIOCSERGETLSR in the trace";
        return record;
    }
    bool enabled = false;
    bool written = false;  // in this window, a write not yet followed by TIOCSERGETLSR
    bool drained = false;
    for (const auto& e : by_thread[sender]) {
        if (e.kind == TraceEvent::Set) {
            record.last_level = e.value;
            const bool on = e.value == active;
            if (enabled && on && drained && record.problem.empty()) {
                record.problem = "enabled for the next request without a release after the last";
            }
            if (enabled && !on) {
                if (written) {
                    ++record.released_early;
                    if (record.problem.empty()) {
                        record.problem = "released after a write and before TIOCSERGETLSR";
                    }
                } else if (drained) {
                    ++record.windows;
                }
            }
            enabled = on;
            written = drained = false;
        } else if (e.fd == port_fd && e.kind == TraceEvent::Write) {
            if (!enabled) {
                ++record.writes_outside;
                if (record.problem.empty()) {
                    record.problem = "a write to the line with the driver not enabled";
                }
            }
            if (!written && !drained) {
                ++record.transmissions;
            }
            written = true;
        } else if (e.fd == port_fd && e.kind == TraceEvent::Lsr && written) {
            written = false;
            drained = true;
        }
    }
    return record;
}

std::string gpio_direction(const std::string& chip, unsigned line, bool active_low) {
    return "direction = \"gpio\"\ngpio_chip = \"" + chip + "\"\ngpio_line = " + std::to_string(line) +
           "\ngpio_active_low = " + (active_low ? "true" : "false") + "\n";
}

// drivebusd with its driver enable on the PL061: the line requested as drivebusd's output with
// the polarity asked, enabled around each request on the kernel's record (set, written, the
// transmitter seen empty, released), reads and a write through it, released at stop.
void gpio_case(const std::string& chip, bool active_low) {
    const auto before = gpio_line_info(kGpioLine);
    ASSERT_TRUE(before) << kGpioChip << " line " << kGpioLine << ": " << std::strerror(errno);
    ASSERT_EQ(before->flags & GPIO_V2_LINE_FLAG_USED, 0U) << "line " << kGpioLine << " is in use before the test";
    KernelTrace trace;
    ASSERT_EQ(trace.error(), "");
    {
        Daemon daemon(write_config("/tmp/gpio.toml", "", gpio_direction(chip, kGpioLine, active_low)));
        ASSERT_TRUE(daemon.ready(180s)) << "drivebusd not ready (exit " << daemon.exit_code(0s) << "):\n"
                                        << Daemon::log();
        const auto pump =
            run({"/usr/bin/drivebusctl", "--json", "--timeout", "10s", "read", "pump", std::to_string(board.reg)});
        EXPECT_EQ(raw_of(pump.out), board.value) << pump.out;
        const auto fan = run({"/usr/bin/drivebusctl", "--json", "--timeout", "10s", "read", "fan", board.fan_register});
        EXPECT_EQ(raw_of(fan.out), board.fan_value) << fan.out;
        const auto held = gpio_line_info(kGpioLine);
        ASSERT_TRUE(held);
        std::printf("line %u while drivebusd runs: flags 0x%llx, consumer \"%s\"\n", kGpioLine,
                    static_cast<unsigned long long>(held->flags), held->consumer);
        EXPECT_NE(held->flags & GPIO_V2_LINE_FLAG_USED, 0U);
        EXPECT_NE(held->flags & GPIO_V2_LINE_FLAG_OUTPUT, 0U);
        EXPECT_EQ((held->flags & GPIO_V2_LINE_FLAG_ACTIVE_LOW) != 0, active_low);
        EXPECT_STREQ(held->consumer, "drivebusd");
        EXPECT_EQ(daemon.stop(), 0) << Daemon::log();
    }
    const auto after = gpio_line_info(kGpioLine);
    ASSERT_TRUE(after);
    EXPECT_EQ(after->flags & GPIO_V2_LINE_FLAG_USED, 0U) << "drivebusd did not release the line";
    const int active = active_low ? 0 : 1;
    const auto record = check_enable(trace.take(), active);
    std::printf(
        "kernel trace: %zu transmissions, %zu of them enabled, written, drained and released; %zu writes "
        "with the driver off; %zu released before the drain; last level %d\n",
        record.transmissions, record.windows, record.writes_outside, record.released_early, record.last_level);
    EXPECT_GE(record.transmissions, 2U) << record.problem;
    EXPECT_EQ(record.windows, record.transmissions) << record.problem;
    EXPECT_EQ(record.writes_outside, 0U) << record.problem;
    EXPECT_EQ(record.released_early, 0U) << record.problem;
    EXPECT_EQ(record.last_level, 1 - active) << "the driver enable was left on";
}

TEST(Packaged, GpioDirectionOnThePl061) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    gpio_case("gpiochip0", false);
}

// The chip by its label, the enable active low: the pin's levels are the other way round.
TEST(Packaged, GpioActiveLowByTheChipsLabel) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    const auto label = gpio_chip_label();
    ASSERT_FALSE(label.empty()) << "GPIO_GET_CHIPINFO_IOCTL: " << std::strerror(errno);
    std::printf("gpiochip0's label: %s\n", label.c_str());
    gpio_case(label, true);
}

// A chip or a line that does not exist cannot appear later: one line, exit 78.
TEST(Packaged, GpioChipOrLineThatDoesNotExistIsRefused) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    const std::vector<std::pair<std::string, std::string>> cases = {
        {gpio_direction("gpiochip9", kGpioLine, false),
         "gpio gpiochip9 line 4: no such GPIO chip (there are gpiochip0)"},
        {gpio_direction("gpiochip0", 99, false), "gpio gpiochip0 line 99: no such line (gpiochip0 \""},
    };
    for (const auto& [direction, expected] : cases) {
        SCOPED_TRACE(direction);
        Daemon daemon(write_config("/tmp/gpio-refused.toml", "", direction));
        EXPECT_FALSE(daemon.ready(180s)) << Daemon::log();
        EXPECT_EQ(daemon.exit_code(60s), 78) << Daemon::log();
        const auto log = Daemon::log();
        std::printf("drivebusd said:\n%s", log.c_str());
        EXPECT_EQ(count_of(log, "error:"), 1U) << log;
        EXPECT_NE(log.find(expected), std::string::npos) << log;
    }
}

// A line another program holds may be released: drivebusd says who holds it, keeps trying,
// and takes it once it is free.
TEST(Packaged, AGpioLineInUseIsWaitedFor) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    int holder = hold_gpio_line(kGpioLine, "holder");
    ASSERT_GE(holder, 0) << "GPIO_V2_GET_LINE_IOCTL: " << std::strerror(errno);
    Daemon daemon(write_config("/tmp/gpio-busy.toml", "", gpio_direction("gpiochip0", kGpioLine, false)));
    ASSERT_TRUE(daemon.ready(180s)) << "drivebusd not ready (exit " << daemon.exit_code(0s) << "):\n" << Daemon::log();
    const auto busy = "gpio gpiochip0 line 4: busy (used by \"holder\")";
    auto deadline = std::chrono::steady_clock::now() + 120s;
    while (!Daemon::log().contains(busy) && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(50ms);
    }
    ASSERT_TRUE(Daemon::log().contains(busy)) << Daemon::log();
    const auto refused = run({"/usr/bin/drivebusctl", "--timeout", "2s", "read", "pump", std::to_string(board.reg)});
    EXPECT_NE(refused.status, 0) << "a read with the bus down:\n" << refused.out;
    std::printf("a read with the line held: exit %d\n%s", refused.status, refused.out.c_str());
    ::close(holder);
    // drivebusd tries again at most 5 s apart.
    Ran read;
    deadline = std::chrono::steady_clock::now() + 120s;
    do {
        read = run({"/usr/bin/drivebusctl", "--json", "--timeout", "5s", "read", "pump", std::to_string(board.reg)});
    } while (read.status != 0 && std::chrono::steady_clock::now() < deadline);
    EXPECT_EQ(raw_of(read.out), board.value) << read.out << Daemon::log();
    const auto info = gpio_line_info(kGpioLine);
    ASSERT_TRUE(info);
    EXPECT_STREQ(info->consumer, "drivebusd");
    EXPECT_EQ(daemon.stop(), 0) << Daemon::log();
    std::printf("drivebusd said:\n%s", Daemon::log().c_str());
}

// --- drivebusctl line-check ------------------------------------------------------------------

// The check a user runs on the board before commissioning, as the packages install it:
// drivebusctl line-check runs /usr/sbin/drivebusd --check-line. Kernel direction with what the
// PL011 keeps, the GPIO line, and a refusal of what it changes.
TEST(Packaged, LineCheckOnThePl011AndThePl061) {
    if (!packages_in_guest()) {
        GTEST_SKIP() << "no packaged programs in this initramfs";
    }
    const auto kernel = run({"/usr/bin/drivebusctl", "line-check", "--config", write_config("/tmp/line.toml", "")});
    std::printf("drivebusctl line-check (kernel):\n%s", kernel.out.c_str());
    EXPECT_EQ(kernel.status, 0) << kernel.out;
    EXPECT_NE(kernel.out.find("  transmitter empty (TIOCSERGETLSR): reported by the driver"), std::string::npos);
    EXPECT_NE(kernel.out.find("  RS485 as asked, and kept by the driver: flags 0x3 (enabled, rts_on_send), delay "
                              "before send 0 ms, after send 0 ms\n"),
              std::string::npos)
        << kernel.out;
    EXPECT_NE(kernel.out.find("  tuning: rx_trig_bytes: not an 8250 UART with a FIFO\n"), std::string::npos)
        << kernel.out;
    EXPECT_NE(kernel.out.find("  drive pump (address 1, atv21): FD01 = "), std::string::npos) << kernel.out;
    EXPECT_NE(kernel.out.find("  2 of 2 drives answered\nbus line: ok\n"), std::string::npos) << kernel.out;

    const auto gpio = run({"/usr/bin/drivebusctl", "line-check", "--config",
                           write_config("/tmp/line.toml", "", gpio_direction("gpiochip0", kGpioLine, false))});
    std::printf("drivebusctl line-check (gpio):\n%s", gpio.out.c_str());
    EXPECT_EQ(gpio.status, 0) << gpio.out;
    EXPECT_NE(gpio.out.find("  driver enable: gpio gpiochip0 line 4, requested: an output of consumer drivebusd, "
                            "active high, at its inactive level\n"),
              std::string::npos)
        << gpio.out;
    EXPECT_NE(gpio.out.find("  2 of 2 drives answered\nbus line: ok\n"), std::string::npos) << gpio.out;
    const auto released = gpio_line_info(kGpioLine);
    ASSERT_TRUE(released);
    EXPECT_EQ(released->flags & GPIO_V2_LINE_FLAG_USED, 0U) << "the line check did not release the line";

    const auto refused = run({"/usr/bin/drivebusctl", "line-check", "--config",
                              write_config("/tmp/line.toml", "rts_on_send = true\nrts_after_send = true\n")});
    std::printf("drivebusctl line-check (refused):\n%s", refused.out.c_str());
    EXPECT_EQ(refused.status, 78) << refused.out;
    EXPECT_NE(refused.out.find("  RS485 as found: "), std::string::npos) << refused.out;
    EXPECT_NE(refused.out.find("the driver changed the RS485 settings: rts_after_send 1 -> 0; ask for what the "
                               "driver keeps"),
              std::string::npos)
        << refused.out;
    EXPECT_EQ(refused.out.find("drive pump"), std::string::npos) << refused.out;
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
    ::mkdir("/dev/shm", 01777);
    ::mount("tmpfs", "/dev/shm", "tmpfs", 0, nullptr);  // iceoryx's shared memory
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
    board.packages = conf.contains("fan");
    if (board.packages) {
        board.fan = static_cast<rtu::SlaveAddress>(word(conf, "fan"));
        board.fan_register = conf.at("fan_register");
        board.fan_value = word(conf, "fan_value");
    }
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
