// SPDX-License-Identifier: Apache-2.0
// drivebus-sim: simulated Altivar drives on a pty (or a given tty), paced at the line's wire
// speed, with fault injection. See docs/simulator.md.
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <csignal>
#include <cstring>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "arrival.hpp"
#include "bus.hpp"
#include "cli/command_line.hpp"
#include "commands.hpp"
#include "control.hpp"
#include "event_log.hpp"
#include "rtu/framer.hpp"
#include "serial/termios.hpp"
#include "setup.hpp"
#include "sys/event_loop.hpp"
#include "writer.hpp"

using namespace drivebus;

namespace {

using sim::fail;
using sim::kExitRuntime;
using sim::kExitUsage;

int run(const sim::Options& o) {
    const rtu::LineFormat format = sim::line_format(o);
    const auto timing = rtu::character_timing(format);
    if (!timing) {
        fail(kExitUsage, std::string(rtu::to_string(timing.error())));
    }
    if (!serial::standard_baud(format.baud)) {
        fail(kExitUsage, "--baud " + std::to_string(format.baud) +
                             ": not a standard rate (9600, 19200, 38400, 57600, 115200, ...)");
    }
    const auto turnaround = sim::option_duration(o.turnaround);
    if (!turnaround) {
        fail(kExitUsage, "--turnaround: " + turnaround.error());
    }

    sim::Bus bus({*timing, *turnaround, o.pace, o.seed});
    sim::add_drives(o, bus, format);
    for (const std::string& f : o.faults) {
        if (auto ok = sim::apply_fault_argument(bus, f); !ok) {
            fail(kExitUsage, ok.error());
        }
    }
    for (const std::string& opt : o.drive_options) {
        if (auto ok = sim::apply_option_argument(bus, opt); !ok) {
            fail(kExitUsage, "--option " + opt + ": " + ok.error());
        }
    }
    for (const std::string& reg : o.registers) {
        if (auto ok = sim::apply_set_argument(bus, reg); !ok) {
            fail(kExitUsage, "--set " + reg + ": " + ok.error());
        }
    }

    // Precise wake-ups for pacing: the default 50 us timer slack would blur every character.
    ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
    if (o.realtime > 0) {
        sched_param param{};
        param.sched_priority = o.realtime;
        if (::sched_setscheduler(0, SCHED_FIFO, &param) != 0) {
            std::cerr << "drivebus-sim: warning: --realtime " << o.realtime << ": " << std::strerror(errno)
                      << "; running with normal priority\n";
        }
    }

    sigset_t signals;
    sigemptyset(&signals);
    for (const int s : {SIGINT, SIGTERM, SIGUSR1, SIGHUP, SIGPIPE}) {
        sigaddset(&signals, s);
    }
    ::sigprocmask(SIG_BLOCK, &signals, nullptr);
    auto made = sys::posix_call("signalfd", [&] { return ::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC); });
    if (!made) {
        fail(kExitRuntime, "cannot watch signals: " + made.error().message());
    }
    const sys::UniqueFd signal_fd(*made);

    sim::Line line = sim::open_line(o, format);
    const bool pty = line.pty.has_value();

    sys::EventLoop loop;
    rtu::Framer framer(*timing, pty ? rtu::InputMarking::Plain : rtu::InputMarking::Parmrk);
    sim::ArrivalModel arrival(timing->character, o.pace);
    sim::PacedWriter writer(line.fd.get(), std::chrono::microseconds(200), timing->t1_5);
    sys::Timer frame_timer;
    int status = 0;

    std::optional<sim::EventLog> tx_log;
    std::optional<sim::EventLog> rx_log;
    try {
        tx_log.emplace(o.tx_log);
        rx_log.emplace(o.rx_log);
    } catch (const std::exception& e) {
        sim::remove_link(line);
        fail(kExitRuntime, std::string("--tx-log/--rx-log: ") + e.what());
    }
    if (tx_log->enabled()) {
        writer.on_reply_end([&](rtu::Instant at, std::uint8_t address, std::uint8_t function) {
            tx_log->record(at, address, function);
        });
    }
    // When the first read of the frame being received returned.
    std::optional<rtu::Instant> frame_first_read;

    auto take_events = [&] {
        while (auto event = framer.next_event()) {
            if (const auto* frame = std::get_if<rtu::Frame>(&*event)) {
                if (frame_first_read) {
                    const auto bytes = frame->adu.bytes();
                    rx_log->record(*frame_first_read, bytes[0], bytes[1]);
                }
                writer.enqueue(bus.on_frame(*frame));
            } else {
                bus.on_discarded(std::get<rtu::DiscardedFrame>(*event));
            }
        }
        if (const auto deadline = framer.deadline()) {
            if (auto armed = frame_timer.arm(*deadline); !armed) {
                std::cerr << "drivebus-sim: frame timer: " << armed.error().message() << '\n';
                status = kExitRuntime;
                loop.stop();
            }
        } else {
            frame_timer.disarm();
        }
    };

    std::vector<std::expected<void, sys::SysError>> added;
    added.push_back(loop.add(line.fd.get(), [&](sys::Readiness ready) {
        std::array<std::uint8_t, 4096> buffer{};
        for (;;) {
            const auto n = sys::posix_call("read", [&] { return ::read(line.fd.get(), buffer.data(), buffer.size()); });
            if (!n && n.error().error == EAGAIN) {
                break;
            }
            // A tty in raw mode (VMIN = VTIME = 0, as --device sets it) answers 0 bytes when
            // nothing is waiting, O_NONBLOCK or not: the line is gone only if epoll said so.
            if (n && *n == 0 && !ready.hung_up) {
                break;
            }
            if (!n || *n == 0) {
                std::cerr << "drivebus-sim: " << line.description << ": line closed ("
                          << (n ? std::string("end of file") : n.error().message()) << ")\n";
                status = kExitRuntime;
                loop.stop();
                return;
            }
            if (bus.muted()) {
                continue;  // the master's bytes go nowhere, and nothing comes back
            }
            const auto bytes = std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(*n));
            const rtu::Instant read_time = sys::now();
            // A new frame begins: how long after our last character did the master start it?
            // (Not after a reply the simulator itself sent late: the master rightly took the
            // hole in it for the end of the line's activity.)
            if (!framer.frame_open()) {
                frame_first_read = read_time;
            }
            if (!framer.frame_open() && writer.last_write()) {
                if (writer.slipped() || writer.stalled(read_time)) {
                    bus.record_slip();
                } else {
                    bus.record_silence(read_time - writer.last_write()->second, read_time - writer.last_write()->first);
                }
                writer.clear_slip();
            }
            const rtu::Instant t = arrival.place(bytes.size(), read_time);
            writer.enqueue(bus.on_received(bytes, t));
            framer.feed(bytes, t);
        }
        take_events();
    }));
    added.push_back(loop.add(frame_timer.fd(), [&] {
        frame_timer.acknowledge();
        framer.poll(sys::now());
        take_events();
    }));
    added.push_back(loop.add(writer.timer_fd(), [&] { writer.service(); }));
    added.push_back(loop.add(signal_fd.get(), [&] {
        signalfd_siginfo info{};
        while (sys::posix_call("read", [&] { return ::read(signal_fd.get(), &info, sizeof info); }) ==
               static_cast<ssize_t>(sizeof info)) {
            if (info.ssi_signo == SIGUSR1) {
                std::cerr << "drivebus-sim: " << bus.counters().to_string() << '\n';
            } else if (info.ssi_signo == SIGINT || info.ssi_signo == SIGTERM) {
                loop.stop();
            }
        }
    }));
    // A mute line ends when the master opens the port again, as a stuck adapter recovers.
    const sys::UniqueFd opens = sim::watch_opens(line);
    if (opens.get() >= 0) {
        added.push_back(loop.add(opens.get(), [&] {
            if (sim::drain_opens(opens.get()) && bus.muted()) {
                bus.set_muted(false);
                std::cerr << "drivebus-sim: the line was opened again: no longer mute\n";
            }
        }));
    }
    for (const auto& a : added) {
        if (!a) {
            std::cerr << "drivebus-sim: event loop: " << a.error().message() << '\n';
            return kExitRuntime;
        }
    }

    std::optional<sim::ControlServer> control;
    if (!o.control.empty()) {
        try {
            control.emplace(loop, o.control, [&](std::string_view command) {
                // Idle: every byte the master sent has been read and framed, and
                // each whole request is in the drives' logs.
                int unread = 0;
                const bool idle = ::ioctl(line.fd.get(), FIONREAD, &unread) == 0 && unread == 0 && !framer.frame_open();
                return sim::run_command(bus, command, sys::now(), idle);
            });
        } catch (const std::exception& e) {
            sim::remove_link(line);
            fail(kExitRuntime, std::string("--control: ") + e.what());
        }
    }

    std::string drives;
    for (const auto address : bus.addresses()) {
        drives += " " + std::to_string(address) + ":" + bus.drive(address)->profile().type;
    }
    std::cerr << "drivebus-sim: " << line.description << ", " << serial::describe(format)
              << (o.pace ? ", paced" : ", not paced") << ", turnaround " << o.turnaround << ", drives" << drives
              << (o.control.empty() ? "" : ", control " + o.control) << '\n';

    if (auto ran = loop.run(); !ran) {
        std::cerr << "drivebus-sim: " << ran.error().message() << '\n';
        status = kExitRuntime;
    }
    control.reset();
    sim::remove_link(line);
    std::cerr << "drivebus-sim: stopped; " << bus.counters().to_string() << '\n';
    return status;
}

}  // namespace

int run_main(int argc, char** argv) {
    sim::Options o;
    CLI::App app{"drivebus-sim: simulated Altivar 21 and Altivar 58 drives on a serial line"};
    cli::add_version(app);
    auto* link = app.add_option("--link", o.link, "make a pty and a symlink PATH to the side a master opens");
    auto* device = app.add_option("--device", o.device, "use this tty instead of a pty");
    link->excludes(device);
    app.add_option("--drive", o.drives, "ADDRESS:TYPE, e.g. 1:atv21 or 2:atv58 (repeat for more)")->required();
    app.add_option("--baud", o.baud, "baud rate")->capture_default_str();
    app.add_option("--data-bits", o.data_bits, "data bits")->check(CLI::Range(5, 8))->capture_default_str();
    app.add_option("--parity", o.parity, "none, even or odd")
        ->check(CLI::IsMember({"none", "even", "odd"}))
        ->capture_default_str();
    app.add_option("--stop-bits", o.stop_bits, "stop bits")->check(CLI::Range(1, 2))->capture_default_str();
    app.add_flag("--pace,!--no-pace", o.pace, "send and receive at the wire speed of the format (default on)");
    app.add_option("--turnaround", o.turnaround, "drive processing time after the end of a request")
        ->capture_default_str();
    app.add_option("--fault", o.faults, "[ADDR:]key=value fault injection (see docs/simulator.md)");
    app.add_option("--option", o.drive_options, "ADDR:key=value drive setting, e.g. 1:load=80");
    app.add_option("--set", o.registers, "ADDR:REG=VALUE a register's value from the start, e.g. 1:F803=0");
    app.add_option("--control", o.control, "control socket PATH for commands while running");
    app.add_option("--seed", o.seed, "seed for the shares of faulty replies")->capture_default_str();
    app.add_option("--profile-dir", o.profile_dir, "directory with the drive profiles (TYPE.toml)");
    app.add_option("--tx-log", o.tx_log, "write 'NS ADDRESS FUNCTION' to PATH after each reply's last byte");
    app.add_option("--rx-log", o.rx_log,
                   "write 'NS ADDRESS FUNCTION' to PATH for each request: when its first byte was read");
    app.add_option("--realtime", o.realtime, "run at this SCHED_FIFO priority (1-99) for tighter pacing")
        ->check(CLI::Range(1, 99));
    const auto exit = cli::parse(app, argc, argv, "drivebus-sim", [&] {
        if (o.link.empty() && o.device.empty()) {
            throw CLI::RequiredError("--link or --device");
        }
    });
    if (exit) {
        return *exit;
    }
    return run(o);
}

int main(int argc, char** argv) {
    // Exceptions only come from building objects at start-up (an epoll or timerfd the kernel
    // refuses); they end the program with one line, not an abort.
    try {
        return run_main(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "drivebus-sim: " << e.what() << '\n';
        return 1;
    }
}
