// SPDX-License-Identifier: Apache-2.0
// drivebus-gateway: Modbus TCP clients (SCADA, HMIs, scripts) reach the drives drivebusd runs,
// through libdrivebus. Reads of polled registers are answered from the shared snapshots; the
// rest goes to drivebusd as any client's requests do. docs/gateway.md.
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <systemd/sd-daemon.h>

#include <fmt/format.h>

#include <iostream>
#include <system_error>

#include "cli/command_line.hpp"
#include "drivebus/version.hpp"
#include "drivebus_backend.hpp"
#include "gateway/config.hpp"
#include "gateway/server.hpp"
#include "log/log.hpp"
#include "sys/event_loop.hpp"

namespace {

using namespace drivebus;
using namespace drivebus::gateway;

constexpr int kExitStartup = 1;
constexpr int kExitDaemonGone = 69;  // EX_UNAVAILABLE: systemd starts the gateway again
constexpr int kExitConfig = 78;
constexpr auto kRetry = std::chrono::seconds(1);

std::string endpoint_text(const Endpoint& e, std::uint16_t port) {
    if (e.host.empty()) {
        return fmt::format("*:{}", port);
    }
    return e.host.find(':') != std::string::npos ? fmt::format("[{}]:{}", e.host, port)
                                                 : fmt::format("{}:{}", e.host, port);
}

sys::UniqueFd block_signals() {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);  // before any thread starts: they inherit it
    return sys::UniqueFd(::signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC));
}

bool wait_signal(int signal_fd, std::chrono::milliseconds timeout) {
    pollfd p{signal_fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) > 0) {
        signalfd_siginfo info{};
        [[maybe_unused]] const auto n = ::read(signal_fd, &info, sizeof info);
        return info.ssi_signo != SIGHUP;
    }
    return false;
}

// Connects, waiting for drivebusd while it does not run yet; nothing when stopped meanwhile.
std::expected<std::unique_ptr<DrivebusBackend>, int> connect(const Config& config, int signal_fd) {
    bool said = false;
    for (;;) {
        auto backend = DrivebusBackend::connect(config);
        if (backend) {
            return std::move(*backend);
        }
        const auto kind = backend.error().kind;
        if (kind != ErrorKind::NotRunning && kind != ErrorKind::NoSuchBus && kind != ErrorKind::DaemonGone) {
            log::error(backend.error().message);
            return std::unexpected(
                kind == ErrorKind::NotPermitted || kind == ErrorKind::InvalidArgument ? kExitConfig : kExitStartup);
        }
        if (!said) {
            log::notice(backend.error().message + ": waiting for it");
            said = true;
        }
        if (wait_signal(signal_fd, kRetry)) {
            return std::unexpected(0);
        }
    }
}

int run_main(int argc, char** argv) {
    std::string config_path = "/etc/drivebus/gateway.toml";
    bool check_only = false;
    bool verbose = false;
    CLI::App app{"drivebus-gateway: Modbus TCP gateway to the drives drivebusd runs"};
    cli::add_version(app);
    app.add_option("--config", config_path, "configuration file (TOML)")->capture_default_str();
    app.add_flag("--check-config", check_only, "validate the configuration and exit (0 valid, 78 not)");
    app.add_flag("--verbose,-v", verbose, "log debug messages");
    if (const auto exit = cli::parse(app, argc, argv, "drivebus-gateway")) {
        return *exit;
    }
    log::init("drivebus-gateway", verbose ? log::Level::Debug : log::Level::Info);
    const auto config = load_config(config_path);
    if (!config) {
        log::error(config.error().message);
        return kExitConfig;
    }
    if (check_only) {
        std::cout << config_path << ": valid, listens on " << endpoint_text(config->listen, config->listen.port)
                  << (config->write_from.empty() ? ", read-only" : ", writes from listed networks") << '\n';
        return 0;
    }
    auto signals = block_signals();
    auto backend = connect(*config, signals.get());
    if (!backend) {
        return backend.error();
    }
    log::route_standard_streams();
    std::unique_ptr<Server> server;
    try {
        server = std::make_unique<Server>(*config, **backend);
    } catch (const std::system_error& e) {
        log::error(std::string("cannot serve: ") + e.what());
        return kExitStartup;
    }
    int status = 0;
    auto& loop = server->loop();
    sys::Timer watch;
    const bool added =
        loop.add(signals.get(),
                 [&] {
                     signalfd_siginfo info{};
                     [[maybe_unused]] const auto n = ::read(signals.get(), &info, sizeof info);
                     if (info.ssi_signo != SIGHUP) {
                         server->stop();
                     }
                 })
            .has_value() &&
        loop.add(watch.fd(),
                 [&] {
                     watch.acknowledge();
                     if (!(*backend)->alive()) {
                         log::error(
                             "drivebusd has gone silent: the gateway ends, for systemd to "
                             "start it again once drivebusd is back");
                         status = kExitDaemonGone;
                         server->stop();
                         return;
                     }
                     const auto s = server->stats();
                     sd_notifyf(0, "STATUS=%llu connections, %llu requests (%llu from snapshots)",
                                static_cast<unsigned long long>(s.open), static_cast<unsigned long long>(s.requests),
                                static_cast<unsigned long long>(s.from_snapshot));
                     (void)watch.arm(sys::now() + kRetry);
                 })
            .has_value() &&
        watch.arm(sys::now() + kRetry).has_value();
    if (!added) {
        log::error("event loop: cannot watch signals and drivebusd");
        return kExitStartup;
    }
    log::notice(fmt::format("listening on {} ({}; {}): {}", endpoint_text(config->listen, server->port()),
                            config->write_from.empty() ? "read-only" : "writes from write_from",
                            fmt::format("max_age {} ms", config->max_age.count()), (*backend)->describe()));
    sd_notify(0, "READY=1");
    try {
        server->run();
    } catch (const std::system_error& e) {
        log::error(e.what());
        status = kExitStartup;
    }
    sd_notify(0, "STOPPING=1");
    const auto s = server->stats();
    log::notice(
        fmt::format("stopped: {} connections served, {} requests ({} from snapshots, {} sent to drivebusd), "
                    "{} refused writes",
                    s.connections, s.requests, s.from_snapshot, s.sent, s.refused_writes));
    return status;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run_main(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "drivebus-gateway: " << e.what() << '\n';
        return kExitStartup;
    }
}
