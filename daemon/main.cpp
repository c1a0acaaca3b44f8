// SPDX-License-Identifier: Apache-2.0
// drivebusd: owns the RS485 lines, is the Modbus RTU master for the drives on them.
//
//   drivebusd --config FILE [--check-config] [--profile-dir DIR] [--verbose]
//
// Exit codes: 0 clean stop (or a valid config with --check-config), 78 bad configuration
// (EX_CONFIG), 2 bad command line, 1 a failure at start-up (real time required and refused).
#include <signal.h>
#include <sys/signalfd.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "bus/bus_loop.hpp"
#include "bus/line_opener.hpp"
#include "config/config.hpp"
#include "drivebus/version.hpp"
#include "ipc/bus_service.hpp"
#include "ipc/host.hpp"
#include "log/log.hpp"
#include "master/line_budget.hpp"
#include "rt/kernel_facts.hpp"
#include "rt/memory.hpp"
#include "rt/realtime.hpp"
#include "serial/termios.hpp"
#include "serial/tuning.hpp"
#include "sys/event_loop.hpp"

using namespace drivebus;

namespace {

constexpr int kExitConfig = 78;
constexpr int kExitUsage = 2;
constexpr int kExitStartup = 1;

std::string describe(const config::Config& c) {
    std::size_t drives = 0;
    for (const auto& b : c.buses) {
        drives += b.drives.size();
    }
    return std::to_string(c.buses.size()) + (c.buses.size() == 1 ? " bus, " : " buses, ") + std::to_string(drives) +
           (drives == 1 ? " drive" : " drives");
}

// For systemd's STATUS=: "line1 up, 2/2 drives online, 1234 replies, 0 timeouts".
std::string status_line(const std::vector<std::unique_ptr<bus::BusLoop>>& loops,
                        const std::vector<std::unique_ptr<ipc::BusService>>& services) {
    std::string out;
    for (std::size_t i = 0; i < loops.size(); ++i) {
        const auto s = loops[i]->status();
        if (!out.empty()) {
            out += "; ";
        }
        out += loops[i]->config().name + (s.up ? " up" : " down") + ", " +
               std::to_string(i < services.size() ? services[i]->drives_online() : 0) + "/" +
               std::to_string(loops[i]->config().drives.size()) + " drives online, " +
               std::to_string(s.counters.replies) + " replies, " + std::to_string(s.counters.timeouts) + " timeouts";
    }
    return out;
}

// The service thread's priority under the bus thread's (rt::service_priority()); refused, a
// warning: the bus itself runs on.
void service_thread_realtime(const config::RealtimeConfig& rt, const std::string& bus) {
    if (rt.mode == config::RealtimeMode::Off) {
        return;
    }
    const auto priority = rt::service_priority(rt.priority);
    if (!priority) {
        log::info("bus " + bus +
                  ": the ipc thread stays at normal priority, the bus threads' priority 1 has "
                  "nothing under it");
        return;
    }
    if (auto done = rt::make_realtime(*priority, {}); !done) {
        log::warning("bus " + bus + ": ipc thread (control leases and their fallback): " + done.error() +
                     "; running at normal priority");
    }
}

std::string fmt_mib(const std::string& before, std::size_t kib) {
    const auto tenths = (kib * 10 + 512) / 1024;
    return before + std::to_string(tenths / 10) + "." + std::to_string(tenths % 10) + " MiB";
}

}  // namespace

int run_main(int argc, char** argv) {
    std::string config_path;
    std::string profile_dir;
    bool check_only = false;
    bool verbose = false;
    CLI::App app{"drivebusd: Modbus RTU master for drives on RS485 lines"};
    app.set_version_flag("--version", std::string(DRIVEBUS_VERSION_STRING));
    app.add_option("--config", config_path, "configuration file (TOML)")->required();
    app.add_flag("--check-config", check_only, "validate the configuration and exit (0 valid, 78 not)");
    app.add_option("--profile-dir", profile_dir, "directory with the drive profiles (TYPE.toml)");
    app.add_flag("--verbose,-v", verbose, "log debug messages");
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "drivebusd: " << e.what() << " (see --help)\n";
        return kExitUsage;
    }
    log::init("drivebusd", verbose ? log::Level::Debug : log::Level::Info);

    config::LoadOptions options;
    if (!profile_dir.empty()) {
        options.profile_dir = profile_dir;
    }
    // Validated once; nothing is opened before the whole configuration is valid.
    const auto config = config::load_config(config_path, options);
    if (!config) {
        log::error(config.error().message);
        return kExitConfig;
    }
    for (const auto& line : config::start_up_warnings(*config)) {
        log::warning(line);
    }
    for (const auto& bus : config->buses) {
        for (const auto& line : master::line_budget_warnings(bus)) {
            log::warning(line);
        }
    }
    for (const auto& bus : config->buses) {
        if (auto usable = bus::check_line(bus); !usable) {
            log::error(usable.error());
            return kExitConfig;
        }
    }
    if (check_only) {
        std::cout << config_path << ": valid, " << describe(*config) << '\n';
        return 0;
    }

    sigset_t signals;
    sigemptyset(&signals);
    for (const int s : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) {
        sigaddset(&signals, s);
    }
    ::pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // every thread inherits the mask
    auto made = sys::posix_call("signalfd", [&] { return ::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC); });
    if (!made) {
        log::error("cannot watch signals: " + made.error().message());
        return kExitStartup;
    }
    const sys::UniqueFd signal_fd(*made);

    const auto& rt = config->realtime;
    auto ipc_host = ipc::Host::start(*config, "drivebusd-" + std::to_string(::getpid()));
    if (!ipc_host) {
        log::error(ipc_host.error());
        return kExitStartup;
    }
    for (const auto& b : config->buses) {
        if (const auto pid = ipc::bus_served_elsewhere(b.name)) {
            log::error("bus " + b.name + " is already served by another drivebusd (pid " + std::to_string(*pid) +
                       "); stop it first, or give this bus another name");
            return kExitStartup;
        }
    }
    log::notice("shared memory: " + (*ipc_host)->describe());
    for (const auto& warning : (*ipc_host)->warnings()) {
        log::warning("shared memory: " + warning);
    }
    for (const auto& note : (*ipc_host)->notes()) {
        log::notice("shared memory: " + note);
    }

    std::vector<std::unique_ptr<ipc::BusService>> services;
    std::vector<std::unique_ptr<bus::BusLoop>> loops;
    // Services first: their threads read their loop's state.
    const auto stop_all = [&] {
        for (auto& s : services) {
            s->stop();
        }
        for (auto& l : loops) {
            l->stop();
        }
    };
    // What stands on the kernel's side between the wire and each bus's reads, once per bus at
    // start-up: a notice where a setting works against exact framing (docs/rs485.md).
    const auto kernel = rt::read_kernel_facts(rt.mode == config::RealtimeMode::Off ? std::vector<int>{} : rt.cpus);
    for (const auto& b : config->buses) {
        for (const auto& finding : rt::judge(kernel, rt::read_port_facts(serial::tty_name(b.device)))) {
            log::write(finding.against_framing ? log::Level::Notice : log::Level::Info,
                       "bus " + b.name + ": " + finding.text);
        }
        // The bus thread and the ipc thread meet only in the loop's hand-over rings.
        bus::LoopOptions loop_options;
        loop_options.realtime = rt;
        loop_options.send_spin = rt.send_spin;
        auto loop = std::make_unique<bus::BusLoop>(b, master::EngineCallbacks{}, std::move(loop_options));
        auto service = std::make_unique<ipc::BusService>(b, (*ipc_host)->layout(), *loop);
        if (auto started = loop->start(); !started) {
            log::error(started.error() + "; [realtime] mode is required");
            stop_all();
            return kExitStartup;
        }
        log::notice("bus " + b.name + ": " + b.device.string() + ", " + serial::describe(b.format) + ", " +
                    std::to_string(b.drives.size()) + " drives");
        service->start([&rt, name = b.name] { service_thread_realtime(rt, name); });
        loops.push_back(std::move(loop));
        services.push_back(std::move(service));
    }
    // Locked once the shared memory is mapped and every thread runs, so that what is locked is
    // what this process has, less iceoryx's management segment (see rt/memory.hpp).
    if (rt.mode != config::RealtimeMode::Off && rt.lock_memory) {
        const std::vector<std::string> left_out{ipc::Host::management_segment()};
        auto locked = rt::lock_memory(left_out);
        if (!locked) {
            if (rt.mode == config::RealtimeMode::Required) {
                log::error(locked.error() + "; [realtime] mode is required");
                stop_all();
                return kExitStartup;
            }
            log::warning(locked.error() + "; running best-effort");
        } else {
            log::info(fmt_mib("memory locked: ", locked->locked_kib) +
                      fmt_mib(" (VmLck); left unlocked: the iceoryx management segment, ", locked->left_out_kib) +
                      " mapped");
        }
    }
    log::notice(std::string("drivebusd ") + DRIVEBUS_VERSION_STRING + " running: " + describe(*config));
    sd_notify(0, "READY=1");

    sys::EventLoop loop;
    sys::Timer status_timer;
    auto signals_added = loop.add(signal_fd.get(), [&] {
        signalfd_siginfo info{};
        while (sys::posix_call("read", [&] { return ::read(signal_fd.get(), &info, sizeof info); }) ==
               static_cast<ssize_t>(sizeof info)) {
            if (info.ssi_signo == SIGINT || info.ssi_signo == SIGTERM) {
                loop.stop();
            }
        }
    });
    // The service watchdog (WatchdogSec=) is fed only while every bus loop keeps going round:
    // a stuck loop stops the feeding and systemd restarts the service.
    std::uint64_t watchdog_usec = 0;
    const bool watchdog = sd_watchdog_enabled(0, &watchdog_usec) > 0;
    std::vector<std::uint64_t> heartbeats(loops.size(), 0);
    auto timer_added = loop.add(status_timer.fd(), [&] {
        status_timer.acknowledge();
        bool alive = true;
        for (std::size_t i = 0; i < loops.size(); ++i) {
            const std::uint64_t beat = loops[i]->heartbeat();
            if (beat == heartbeats[i]) {
                alive = false;
                log::error("bus " + loops[i]->config().name + ": its event loop has not run for a second");
            }
            heartbeats[i] = beat;
        }
        if (watchdog && alive) {
            sd_notify(0, "WATCHDOG=1");
        }
        sd_notifyf(0, "STATUS=%s", status_line(loops, services).c_str());
        if (auto armed = status_timer.arm(sys::now() + std::chrono::seconds(1)); !armed) {
            log::error("status timer: " + armed.error().message() + "; the watchdog is no longer fed");
        }
    });
    if (!signals_added || !timer_added) {
        log::error("event loop: " + (!signals_added ? signals_added : timer_added).error().message());
        stop_all();
        return kExitStartup;
    }
    if (auto armed = status_timer.arm(sys::now() + std::chrono::seconds(1)); !armed) {
        log::error("status timer: " + armed.error().message());
        stop_all();
        return kExitStartup;
    }
    (void)loop.run();

    sd_notify(0, "STOPPING=1");
    stop_all();
    log::notice("stopped: " + status_line(loops, services));
    return 0;
}

int main(int argc, char** argv) {
    // Exceptions only come from building objects at start-up (an epoll or timerfd the kernel
    // refuses); they end the program with one line, not an abort.
    try {
        return run_main(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "drivebusd: " << e.what() << '\n';
        return 1;
    }
}
