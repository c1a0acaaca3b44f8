// SPDX-License-Identifier: Apache-2.0
// drivebusd: owns the RS485 lines, is the Modbus RTU master for the drives on them.
//
//   drivebusd --config FILE [--check-config] [--profile-dir DIR] [--verbose]
//   drivebusd --config FILE --check-line [--bus NAME]     (drivebusctl line-check)
//   drivebusd --config FILE --gpio-lines                  (drivebusctl udev-rule --config)
//
// The command line, the signals and the event loop; what runs is the supervisor's.
// Exit codes: 0 clean stop (or a valid config with --check-config, a line that works with
// --check-line), 78 bad configuration (EX_CONFIG), 2 bad command line, 1 a failure at
// start-up (real time required and refused) or a line check that failed.
#include <signal.h>
#include <sys/signalfd.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <iostream>
#include <memory>
#include <string>

#include "bus/line_check.hpp"
#include "cli/command_line.hpp"
#include "config/config.hpp"
#include "drivebus/version.hpp"
#include "log/log.hpp"
#include "supervisor.hpp"
#include "sys/event_loop.hpp"
#include "sys/posix.hpp"

using namespace drivebus;

namespace {

constexpr int kExitConfig = 78;
constexpr int kExitStartup = 1;

// For drivebusctl udev-rule: each direction = "gpio" bus as "BUS<tab>CHIP<tab>LINE", as written.
void print_gpio_lines(const config::Config& c, std::ostream& out) {
    for (const auto& bus : c.buses) {
        if (bus.direction == config::DirectionMode::Gpio && bus.gpio) {
            out << bus.name << '\t' << bus.gpio->chip << '\t' << bus.gpio->line << '\n';
        }
    }
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
    cli::add_version(app);
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
    if (const auto exit = cli::parse(app, argc, argv, "drivebusd")) {
        return *exit;
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
        daemon::warn(*config);
        return bus::check_lines(*config, bus::LineCheckOptions{.bus = line_bus}, std::cout);
    }
    if (auto checked = daemon::check_and_warn(*config); !checked) {
        log::error(checked.error());
        return kExitConfig;
    }
    if (check_only) {
        std::cout << config_path << ": valid, " << daemon::describe(*config) << '\n';
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

    auto supervisor = daemon::Supervisor::start(std::move(*config), config_path, options);
    if (!supervisor) {
        return kExitStartup;  // logged
    }
    log::notice(std::string("drivebusd ") + DRIVEBUS_VERSION_STRING +
                " running: " + daemon::describe(supervisor->config()));
    sd_notify(0, "READY=1");

    sys::EventLoop loop;
    sys::Timer status_timer;
    auto signals_added = loop.add(signal_fd.get(), [&] {
        signalfd_siginfo info{};
        while (sys::posix_call("read", [&] { return ::read(signal_fd.get(), &info, sizeof info); }) ==
               static_cast<ssize_t>(sizeof info)) {
            if (info.ssi_signo == SIGINT || info.ssi_signo == SIGTERM) {
                loop.stop();
            } else if (info.ssi_signo == SIGHUP) {
                sd_notify(0, "RELOADING=1");
                supervisor->reload();
                sd_notifyf(0, "READY=1\nSTATUS=%s", supervisor->status_line().c_str());
            }
        }
    });
    // The service watchdog (WatchdogSec=) is fed only while every bus loop keeps going round:
    // a stuck loop stops the feeding and systemd restarts the service.
    std::uint64_t watchdog_usec = 0;
    const bool watchdog = sd_watchdog_enabled(0, &watchdog_usec) > 0;
    auto timer_added = loop.add(status_timer.fd(), [&] {
        status_timer.acknowledge();
        const bool alive = supervisor->heartbeat();
        if (watchdog && alive) {
            sd_notify(0, "WATCHDOG=1");
        }
        sd_notifyf(0, "STATUS=%s", supervisor->status_line().c_str());
        if (auto armed = status_timer.arm(sys::now() + std::chrono::seconds(1)); !armed) {
            log::error("status timer: " + armed.error().message() + "; the watchdog is no longer fed");
        }
    });
    if (!signals_added || !timer_added) {
        log::error("event loop: " + (!signals_added ? signals_added : timer_added).error().message());
        supervisor->stop();
        return kExitStartup;
    }
    if (auto armed = status_timer.arm(sys::now() + std::chrono::seconds(1)); !armed) {
        log::error("status timer: " + armed.error().message());
        supervisor->stop();
        return kExitStartup;
    }
    (void)loop.run();

    sd_notify(0, "STOPPING=1");
    const auto last = supervisor->status_line();
    supervisor->stop();
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
