// SPDX-License-Identifier: Apache-2.0
// drivebusd: owns the RS485 lines, is the Modbus RTU master for the drives on them.
//
//   drivebusd --config FILE [--check-config] [--profile-dir DIR] [--verbose]
//   drivebusd --config FILE --check-line [--bus NAME]     (drivebusctl line-check)
//
// Exit codes: 0 clean stop (or a valid config with --check-config, a line that works with
// --check-line), 78 bad configuration (EX_CONFIG), 2 bad command line, 1 a failure at
// start-up (real time required and refused) or a line check that failed.
#include <signal.h>
#include <sys/signalfd.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bus/bus_loop.hpp"
#include "bus/line_check.hpp"
#include "bus/line_opener.hpp"
#include "config/config.hpp"
#include "config/reload.hpp"
#include "drivebus/version.hpp"
#include "ipc/bus_service.hpp"
#include "ipc/host.hpp"
#include "log/log.hpp"
#include "master/comm_timeout.hpp"
#include "master/line_budget.hpp"
#include "rt/kernel_facts.hpp"
#include "rt/memory.hpp"
#include "running_bus.hpp"
#include "serial/tuning.hpp"
#include "sys/event_loop.hpp"

using namespace drivebus;
using daemon::RunningBus;

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
std::string status_line(const std::vector<RunningBus>& buses) {
    std::string out;
    for (const auto& b : buses) {
        const auto s = b.loop->status();
        if (!out.empty()) {
            out += "; ";
        }
        out += b.config->name + (s.up ? " up" : " down") + ", " + std::to_string(b.service->drives_online()) + "/" +
               std::to_string(b.config->drives.size()) + " drives online, " + std::to_string(s.counters.replies) +
               " replies, " + std::to_string(s.counters.timeouts) + " timeouts";
    }
    return out;
}

std::string fmt_mib(const std::string& before, std::size_t kib) {
    const auto tenths = (kib * 10 + 512) / 1024;
    return before + std::to_string(tenths / 10) + "." + std::to_string(tenths % 10) + " MiB";
}

// Warnings a configuration still leaves.
void warn(const config::Config& c) {
    for (const auto& line : config::start_up_warnings(c)) {
        log::warning(line);
    }
    for (const auto& bus : c.buses) {
        for (const auto& line : master::line_budget_warnings(bus)) {
            log::warning(line);
        }
        for (const auto& line : master::comm_timeout_warnings(bus)) {
            log::warning(line);
        }
    }
}

// For drivebusctl udev-rule: each direction = "gpio" bus as "BUS<tab>CHIP<tab>LINE", as written.
void print_gpio_lines(const config::Config& c, std::ostream& out) {
    for (const auto& bus : c.buses) {
        if (bus.direction == config::DirectionMode::Gpio && bus.gpio) {
            out << bus.name << '\t' << bus.gpio->chip << '\t' << bus.gpio->line << '\n';
        }
    }
}

// The warnings, and the permanent misconfigurations of the lines (a GPIO chip that is not
// there, RS485 the driver lacks): the first of those is the error.
std::expected<void, std::string> check_and_warn(const config::Config& c) {
    warn(c);
    for (const auto& bus : c.buses) {
        if (auto usable = bus::check_line(bus); !usable) {
            return std::unexpected(usable.error());
        }
    }
    return {};
}

}  // namespace

int run_main(int argc, char** argv) {
    std::string config_path;
    std::string profile_dir;
    bool check_only = false;
    bool check_line = false;
    bool gpio_lines = false;
    std::string line_bus;
    bool verbose = false;
    CLI::App app{"drivebusd: Modbus RTU master for drives on RS485 lines"};
    app.set_version_flag("--version", std::string(DRIVEBUS_VERSION_STRING));
    app.add_option("--config", config_path, "configuration file (TOML)")->required();
    app.add_flag("--check-config", check_only, "validate the configuration and exit (0 valid, 78 not)");
    auto* line_flag = app.add_flag("--check-line", check_line,
                                   "check each bus's line and read each drive once, with drivebusd stopped (0 all "
                                   "answered, 1 not, 78 what the configuration asks cannot be had)");
    app.add_option("--bus", line_bus, "with --check-line: only this bus")->needs(line_flag);
    app.add_flag("--gpio-lines", gpio_lines,
                 "print each direction = \"gpio\" bus as BUS, CHIP and LINE (tab-separated) once the configuration "
                 "is valid, and exit; nothing is opened (drivebusctl udev-rule --config)")
        ->excludes(line_flag);
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
    log::init("drivebusd", verbose ? log::Level::Debug : (check_line ? log::Level::Warning : log::Level::Info));

    config::LoadOptions options;
    if (!profile_dir.empty()) {
        options.profile_dir = profile_dir;
    }
    if (auto state_dir = config::state_dir_from_environment()) {
        options.state_dir = std::move(*state_dir);
    } else {
        log::error(state_dir.error().message);
        return kExitConfig;
    }
    // Validated once; nothing is opened before the whole configuration is valid.
    auto config = config::load_config(config_path, options);
    if (!config) {
        log::error(config.error().message);
        return kExitConfig;
    }
    if (gpio_lines) {
        print_gpio_lines(*config, std::cout);
        return 0;
    }
    if (check_line) {
        warn(*config);
        return bus::check_lines(*config, bus::LineCheckOptions{.bus = line_bus}, std::cout);
    }
    if (auto checked = check_and_warn(*config); !checked) {
        log::error(checked.error());
        return kExitConfig;
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

    const auto rt = config->realtime;
    auto ipc_host = ipc::Host::start(*config, "drivebusd-" + std::to_string(::getpid()));
    if (!ipc_host) {
        log::error(ipc_host.error());
        return kExitStartup;
    }
    for (const auto& b : config->buses) {
        if (const auto pid = ipc::bus_served_elsewhere(b.name)) {
            log::error("bus " + b.name + " is already served by another drivebusd (pid " + std::to_string(*pid) +
                           "); stop it first, or give this bus another name",
                       {.bus = b.name});
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

    // The running buses. Stopped for good, each first writes its held leases' fallbacks.
    std::vector<RunningBus> buses;
    const auto stop_all = [&] { daemon::end_buses(buses); };
    const auto kernel = rt::read_kernel_facts(rt.mode == config::RealtimeMode::Off ? std::vector<int>{} : rt.cpus);
    for (const auto& b : config->buses) {
        auto started = daemon::start_bus(b, rt, (*ipc_host)->layout(), kernel, {});
        if (!started) {
            log::error(started.error());
            stop_all();
            return kExitStartup;
        }
        buses.push_back(std::move(*started));
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

    // SIGHUP: the configuration read and checked again; applied only whole. A bus whose
    // settings changed is restarted with its leases; the others, and every client, go on.
    const auto reload = [&] {
        log::notice("reload: reading " + config_path);
        auto next = config::load_config(config_path, options);
        if (!next) {
            log::error("reload refused, the running configuration stays: " + next.error().message);
            return;
        }
        auto plan = config::plan_reload(*config, *next);
        if (!plan) {
            log::error("reload refused, the running configuration stays: " + plan.error());
            return;
        }
        if ((*ipc_host)->embedded()) {
            auto needed = ipc::plan_layout(*next);
            if (!needed) {
                log::error("reload refused, the running configuration stays: " + needed.error());
                return;
            }
            if (const auto short_of = ipc::layout_shortfall((*ipc_host)->layout(), *needed)) {
                log::error("reload refused, the running configuration stays: " + *short_of +
                           "; restart drivebusd to apply it (systemctl restart drivebusd)");
                return;
            }
        }
        if (auto checked = check_and_warn(*next); !checked) {
            log::error("reload refused, the running configuration stays: " + checked.error());
            return;
        }
        for (const auto& name : plan->start) {
            if (const auto pid = ipc::bus_served_elsewhere(name)) {
                log::error("reload refused, the running configuration stays: bus " + name +
                           " is already served by another drivebusd (pid " + std::to_string(*pid) + ")");
                return;
            }
        }
        const auto in = [](const std::vector<std::string>& names, const std::string& name) {
            return std::ranges::find(names, name) != names.end();
        };
        std::map<std::string, ipc::Carried> carried;
        std::vector<RunningBus> kept;
        std::vector<RunningBus> dropped;
        for (auto& b : buses) {
            if (in(plan->keep, b.config->name)) {
                kept.push_back(std::move(b));
            } else if (in(plan->stop, b.config->name)) {
                dropped.push_back(std::move(b));
            } else {
                carried[b.config->name] = daemon::restart_bus(b);
            }
        }
        daemon::end_buses(dropped);
        buses = std::move(kept);
        const auto now_rt = next->realtime;
        for (const auto& settings : next->buses) {
            if (in(plan->keep, settings.name)) {
                continue;
            }
            auto started = daemon::start_bus(settings, now_rt, (*ipc_host)->layout(), kernel, carried[settings.name]);
            if (!started) {
                // Only a refused real-time priority, with mode = "required": nothing else differs
                // from the start, which was granted it.
                log::error("reload: bus " + settings.name + " not started: " + started.error(), {.bus = settings.name});
                continue;
            }
            buses.push_back(std::move(*started));
        }
        // Each bus in the order of the configuration.
        std::ranges::sort(buses, {}, [&](const RunningBus& b) {
            return std::ranges::find(next->buses, b.config->name, &config::BusConfig::name) - next->buses.begin();
        });
        log::notice("reload: " + config::describe(*plan) + "; running: " + describe(*next));
        config = std::move(next);
    };

    sys::EventLoop loop;
    sys::Timer status_timer;
    std::map<std::string, std::uint64_t> heartbeats;  // by bus: a restarted bus starts again
    auto signals_added = loop.add(signal_fd.get(), [&] {
        signalfd_siginfo info{};
        while (sys::posix_call("read", [&] { return ::read(signal_fd.get(), &info, sizeof info); }) ==
               static_cast<ssize_t>(sizeof info)) {
            if (info.ssi_signo == SIGINT || info.ssi_signo == SIGTERM) {
                loop.stop();
            } else if (info.ssi_signo == SIGHUP) {
                sd_notify(0, "RELOADING=1");
                reload();
                heartbeats.clear();
                sd_notifyf(0, "READY=1\nSTATUS=%s", status_line(buses).c_str());
            }
        }
    });
    // The service watchdog (WatchdogSec=) is fed only while every bus loop keeps going round:
    // a stuck loop stops the feeding and systemd restarts the service.
    std::uint64_t watchdog_usec = 0;
    const bool watchdog = sd_watchdog_enabled(0, &watchdog_usec) > 0;
    auto timer_added = loop.add(status_timer.fd(), [&] {
        status_timer.acknowledge();
        bool alive = true;
        for (const auto& b : buses) {
            const std::uint64_t beat = b.loop->heartbeat();
            if (const auto it = heartbeats.find(b.config->name); it != heartbeats.end() && beat == it->second) {
                alive = false;
                log::error("bus " + b.config->name + ": its event loop has not run for a second",
                           {.bus = b.config->name});
            }
            heartbeats[b.config->name] = beat;
        }
        if (watchdog && alive) {
            sd_notify(0, "WATCHDOG=1");
        }
        sd_notifyf(0, "STATUS=%s", status_line(buses).c_str());
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
    const auto last = status_line(buses);
    stop_all();
    log::notice("stopped: " + last);
    return 0;
}

int main(int argc, char** argv) {
    // Exceptions only come from building objects at start-up (an epoll or timerfd the kernel
    // refuses); they end the program with one line, not an abort.
    try {
        return run_main(argc, argv);
    } catch (const std::exception& e) {
        log::error(e.what());  // std::cerr goes through the log once iceoryx runs
        return 1;
    }
}
