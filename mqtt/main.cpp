// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt: publishes the drives of drivebusd's buses on an MQTT broker, and takes
// commands for the drives its configuration enables (docs/mqtt.md).
//
//   drivebus-mqtt --config FILE [--check-config] [--verbose]
//
// Exit codes: 0 clean stop (or a valid config with --check-config), 78 bad configuration
// (EX_CONFIG; also a password file or TLS key others may read: mqtt/core/include/mqtt/secret.hpp),
// 2 bad command line, 1 a failure at start-up.
#include <signal.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bridge.hpp"
#include "cli/command_line.hpp"
#include "drivebus/version.hpp"
#include "log/log.hpp"
#include "mqtt/config.hpp"
#include "secret_facts.hpp"

using namespace drivebus;

namespace {

constexpr int kExitConfig = 78;
constexpr int kExitStartup = 1;

// The password file and the TLS key, as mqtt::secret_problem() requires them; why not, else.
std::optional<std::string> secrets_problem(const mqtt::Config& config) {
    std::vector<std::pair<std::string, std::filesystem::path>> secrets;
    if (!config.broker.password_file.empty()) {
        secrets.emplace_back("broker.password_file", config.broker.password_file);
    }
    if (config.broker.tls && !config.broker.tls->keyfile.empty()) {
        secrets.emplace_back("broker.tls.keyfile", config.broker.tls->keyfile);
    }
    const auto me = mqtt::this_account();
    for (auto& [key, path] : secrets) {
        const auto file = mqtt::read_secret_file(key, path);
        if (!file) {
            return file.error();
        }
        if (auto problem = mqtt::secret_problem(*file, me)) {
            return problem;
        }
    }
    return std::nullopt;
}

std::string hostname() {
    std::array<char, 256> name{};
    if (::gethostname(name.data(), name.size() - 1) != 0) {
        return "localhost";
    }
    return name.data();
}

int run_main(int argc, char** argv) {
    std::string config_path = "/etc/drivebus/mqtt.toml";
    bool check_only = false;
    bool verbose = false;
    CLI::App app{"drivebus-mqtt: drivebus drives on an MQTT broker"};
    cli::add_version(app);
    app.add_option("--config", config_path, "configuration file (TOML)");
    app.add_flag("--check-config", check_only, "validate the configuration and exit (0 valid, 78 not)");
    app.add_flag("--verbose,-v", verbose, "log debug messages");
    if (const auto exit = cli::parse(app, argc, argv, "drivebus-mqtt")) {
        return *exit;
    }
    log::init("drivebus-mqtt", verbose ? log::Level::Debug : log::Level::Info);
    const auto config = mqtt::load_config(config_path, hostname());
    if (!config) {
        log::error(config.error().message);
        return kExitConfig;
    }
    if (const auto problem = secrets_problem(*config)) {
        log::error(*problem);
        return kExitConfig;
    }
    if (check_only) {
        std::cout << config_path << ": valid, node " << config->node << ", broker " << config->broker.host << ":"
                  << config->broker.port << ", " << config->buses.size()
                  << (config->buses.size() == 1 ? " bus\n" : " buses\n");
        return 0;
    }
    log::route_standard_streams();

    // Signals are taken by this thread alone (sigwait): every thread started below inherits the mask.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    ::signal(SIGPIPE, SIG_IGN);

    std::unique_ptr<mqtt::Bridge> bridge;
    try {
        bridge = std::make_unique<mqtt::Bridge>(*config);
    } catch (const std::exception& e) {
        log::error(e.what());
        return kExitStartup;
    }
    std::thread runner([&] { bridge->run(); });
    log::notice("running: node " + config->node + ", broker " + config->broker.host + ":" +
                std::to_string(config->broker.port) + (config->broker.tls ? " (TLS)" : "") + ", " +
                std::to_string(config->buses.size()) + (config->buses.size() == 1 ? " bus" : " buses"));
    sd_notify(0, "READY=1");
    for (;;) {
        int signal = 0;
        if (sigwait(&signals, &signal) != 0) {
            continue;
        }
        if (signal == SIGHUP) {
            log::info("SIGHUP: the configuration is read at start only; restart to apply a new one");
            continue;
        }
        break;
    }
    sd_notify(0, "STOPPING=1");
    bridge->stop();
    runner.join();
    bridge.reset();
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run_main(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "drivebus-mqtt: " << e.what() << '\n';
        return kExitStartup;
    }
}
