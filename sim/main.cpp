// drivebus-sim: simulated Altivar drives on a pty (or a given tty), paced at the line's wire
// speed, with fault injection. See docs/simulator.md.
#include <fcntl.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "arrival.hpp"
#include "bus.hpp"
#include "commands.hpp"
#include "control.hpp"
#include "event_log.hpp"
#include "drivebus/profile.hpp"
#include "rtu/framer.hpp"
#include "serial/pty.hpp"
#include "serial/termios.hpp"
#include "sys/event_loop.hpp"
#include "writer.hpp"

namespace fs = std::filesystem;
using namespace drivebus;

namespace {

constexpr int kExitUsage = 2;
constexpr int kExitRuntime = 1;

struct Options {
    std::string link;
    std::string device;
    std::vector<std::string> drives;
    std::uint32_t baud = 19200;
    unsigned data_bits = 8;
    std::string parity = "none";
    unsigned stop_bits = 1;
    bool pace = true;
    std::string turnaround = "1ms";
    std::vector<std::string> faults;
    std::vector<std::string> drive_options;
    std::string control;
    std::uint32_t seed = 1;
    std::string profile_dir;
    int realtime = 0;
    std::string tx_log;
    std::string rx_log;
};

struct Line {
    sys::UniqueFd fd;  // what the simulator reads and writes
    std::optional<serial::PtyPair> pty;
    fs::path link;  // removed on exit
    std::string description;
};

[[noreturn]] void fail(int code, const std::string& message) {
    std::cerr << "drivebus-sim: " << message << '\n';
    std::exit(code);
}

rtu::LineFormat line_format(const Options& o) {
    rtu::LineFormat f;
    f.baud = o.baud;
    f.data_bits = static_cast<std::uint8_t>(o.data_bits);
    f.parity = o.parity == "even" ? rtu::Parity::Even : (o.parity == "odd" ? rtu::Parity::Odd : rtu::Parity::None);
    f.stop_bits = static_cast<std::uint8_t>(o.stop_bits);
    return f;
}

std::shared_ptr<const Profile> profile_for(const Options& o, const std::string& type,
                                           std::map<std::string, std::shared_ptr<const Profile>>& cache) {
    if (const auto it = cache.find(type); it != cache.end()) {
        return it->second;
    }
    auto loaded =
        o.profile_dir.empty() ? load_profile_by_type(type) : load_profile(fs::path(o.profile_dir) / (type + ".toml"));
    if (!loaded) {
        fail(kExitUsage, "--drive ...:" + type + ": " + loaded.error().message);
    }
    auto profile = std::make_shared<const Profile>(std::move(*loaded));
    cache[type] = profile;
    return profile;
}

void add_drives(const Options& o, sim::Bus& bus, const rtu::LineFormat& format) {
    std::map<std::string, std::shared_ptr<const Profile>> cache;
    for (const std::string& spec : o.drives) {
        const auto colon = spec.find(':');
        unsigned address = 0;
        if (colon == std::string::npos || std::sscanf(spec.substr(0, colon).c_str(), "%u", &address) != 1) {
            fail(kExitUsage, "--drive " + spec + ": expected ADDRESS:TYPE, such as 1:atv21");
        }
        const std::string type = spec.substr(colon + 1);
        auto profile = profile_for(o, type, cache);
        if (address < profile->address_min || address > profile->address_max) {
            fail(kExitUsage, "--drive " + spec + ": an " + profile->title + " takes addresses " +
                                 std::to_string(profile->address_min) + "-" + std::to_string(profile->address_max));
        }
        if (bus.drive(static_cast<rtu::SlaveAddress>(address)) != nullptr) {
            fail(kExitUsage, "--drive " + spec + ": address " + std::to_string(address) + " is taken twice");
        }
        const auto& parities = profile->parities;
        if (!parities.empty() && std::ranges::find(parities, o.parity) == parities.end()) {
            std::cerr << "drivebus-sim: warning: an " << profile->title << " does not offer parity " << o.parity
                      << "; simulating it anyway\n";
        }
        std::unique_ptr<sim::ProfileDrive> drive;
        try {
            drive = sim::make_drive(static_cast<rtu::SlaveAddress>(address), profile);
        } catch (const std::exception& e) {
            fail(kExitUsage, "--drive " + spec + ": " + e.what());
        }
        // An Altivar 21 on this line has been set to its format (F800 baud, F801 parity).
        if (type == "atv21") {
            (void)drive->poke("F800", format.baud == 9600 ? 0 : 1);
            (void)drive->poke("F801", static_cast<std::uint16_t>(format.parity == rtu::Parity::None   ? 0
                                                                 : format.parity == rtu::Parity::Even ? 1
                                                                                                      : 2));
            (void)drive->poke("F802", static_cast<std::uint16_t>(address));
        }
        bus.add(std::move(drive));
    }
}

Line open_line(const Options& o, const rtu::LineFormat& format) {
    Line line;
    if (!o.link.empty()) {
        auto pty = serial::open_pty();
        if (!pty) {
            fail(kExitRuntime, "cannot open a pty: " + pty.error().message());
        }
        line.link = o.link;
        std::error_code ec;
        const auto status = fs::symlink_status(line.link, ec);
        if (fs::exists(status) && !fs::is_symlink(status)) {
            fail(kExitUsage, "--link " + o.link + ": exists and is not a symlink; not replacing it");
        }
        fs::remove(line.link, ec);
        fs::create_symlink(pty->slave_path, line.link, ec);
        if (ec) {
            fail(kExitRuntime, "--link " + o.link + ": " + ec.message());
        }
        (void)serial::configure_line(pty->slave.get(), format, serial::ErrorMarking::Off);
        line.fd.reset(pty->master.release());
        line.description = o.link + " -> " + pty->slave_path.string();
        line.pty = std::move(*pty);
        return line;
    }
    auto fd =
        sys::posix_call("open", [&] { return ::open(o.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
    if (!fd) {
        fail(kExitRuntime, "--device " + o.device + ": " + fd.error().message());
    }
    line.fd.reset(*fd);
    if (::ioctl(line.fd.get(), TIOCEXCL) != 0) {
        fail(kExitRuntime, "--device " + o.device + ": cannot take it exclusively: " + std::strerror(errno));
    }
    if (auto ok = serial::configure_line(line.fd.get(), format, serial::ErrorMarking::Parmrk); !ok) {
        fail(kExitRuntime, "--device " + o.device + ": " + ok.error().message());
    }
    line.description = o.device;
    return line;
}

void remove_link(const Line& line) {
    if (line.link.empty() || !line.pty) {
        return;
    }
    std::error_code ec;
    if (fs::is_symlink(line.link, ec) && fs::read_symlink(line.link, ec) == line.pty->slave_path) {
        fs::remove(line.link, ec);
    }
}

int run(const Options& o) {
    const rtu::LineFormat format = line_format(o);
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
    add_drives(o, bus, format);
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
    sys::UniqueFd signal_fd(::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC));

    Line line = open_line(o, format);
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
        remove_link(line);
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
    added.push_back(loop.add(line.fd.get(), [&] {
        std::array<std::uint8_t, 4096> buffer{};
        for (;;) {
            const auto n = ::read(line.fd.get(), buffer.data(), buffer.size());
            if (n < 0 && errno == EINTR) {
                continue;
            }
            if (n < 0 && errno == EAGAIN) {
                break;
            }
            if (n <= 0) {
                std::cerr << "drivebus-sim: " << line.description << ": line closed (" << std::strerror(errno) << ")\n";
                status = kExitRuntime;
                loop.stop();
                return;
            }
            const auto bytes = std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n));
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
        while (::read(signal_fd.get(), &info, sizeof info) == sizeof info) {
            if (info.ssi_signo == SIGUSR1) {
                std::cerr << "drivebus-sim: " << bus.counters().to_string() << '\n';
            } else if (info.ssi_signo == SIGINT || info.ssi_signo == SIGTERM) {
                loop.stop();
            }
        }
    }));
    for (const auto& a : added) {
        if (!a) {
            std::cerr << "drivebus-sim: event loop: " << a.error().message() << '\n';
            return kExitRuntime;
        }
    }

    std::optional<sim::ControlServer> control;
    if (!o.control.empty()) {
        try {
            control.emplace(loop, o.control,
                            [&](std::string_view command) { return sim::run_command(bus, command, sys::now()); });
        } catch (const std::exception& e) {
            remove_link(line);
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
    remove_link(line);
    std::cerr << "drivebus-sim: stopped; " << bus.counters().to_string() << '\n';
    return status;
}

}  // namespace

int run_main(int argc, char** argv) {
    Options o;
    CLI::App app{"drivebus-sim: simulated Altivar 21 and Altivar 58 drives on a serial line"};
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
    app.add_option("--control", o.control, "control socket PATH for commands while running");
    app.add_option("--seed", o.seed, "seed for the shares of faulty replies")->capture_default_str();
    app.add_option("--profile-dir", o.profile_dir, "directory with the drive profiles (TYPE.toml)");
    app.add_option("--tx-log", o.tx_log, "write 'NS ADDRESS FUNCTION' to PATH after each reply's last byte");
    app.add_option("--rx-log", o.rx_log, "write 'NS ADDRESS FUNCTION' to PATH for each request: when its first byte was read");
    app.add_option("--realtime", o.realtime, "run at this SCHED_FIFO priority (1-99) for tighter pacing")
        ->check(CLI::Range(1, 99));
    try {
        app.parse(argc, argv);
        if (o.link.empty() && o.device.empty()) {
            throw CLI::RequiredError("--link or --device");
        }
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "drivebus-sim: " << e.what() << " (see --help)\n";
        return kExitUsage;
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
