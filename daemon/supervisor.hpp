// SPDX-License-Identifier: Apache-2.0
// What drivebusd runs once its configuration is valid: the shared memory (and the RouDi it may
// embed), every bus started, the memory locked; a reload (SIGHUP) applied whole or refused;
// each second, the buses' heartbeats (the systemd watchdog is fed only while every bus loop
// goes round) and the status line; and the stop, when every held lease first gets its drive's
// fallback. main() owns the command line, the signals and the event loop.
#pragma once

#include <cstdint>
#include <expected>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "ipc/host.hpp"
#include "rt/kernel_facts.hpp"
#include "running_bus.hpp"

namespace drivebus::daemon {

// "1 bus, 2 drives".
[[nodiscard]] std::string describe(const config::Config& c);

// The configuration's warnings, in the log.
void warn(const config::Config& c);

// The warnings, and the permanent misconfigurations of the lines (a GPIO chip that is not
// there, RS485 the driver lacks): the first of those is the error.
[[nodiscard]] std::expected<void, std::string> check_and_warn(const config::Config& c);

class Supervisor {
public:
    // Maps the shared memory and starts every bus, then locks memory as [realtime] asks. Null
    // when it cannot: the reason is logged (with the bus), and what it started has stopped.
    static std::unique_ptr<Supervisor> start(config::Config config, std::filesystem::path file,
                                             config::LoadOptions options);
    ~Supervisor();
    Supervisor(const Supervisor&) = delete;
    Supervisor& operator=(const Supervisor&) = delete;
    Supervisor(Supervisor&&) = delete;
    Supervisor& operator=(Supervisor&&) = delete;

    // Reads and checks the file again and applies it whole, or logs why not and keeps the
    // running configuration. A bus whose settings changed restarts with its leases.
    void reload();
    // Once a second: false when a bus loop has not gone round since the last call (logged).
    [[nodiscard]] bool heartbeat();
    // For systemd's STATUS=: "line1 up, 2/2 drives online, 1234 replies, 0 timeouts".
    [[nodiscard]] std::string status_line() const;
    // Stops every bus for good (their leases' fallbacks first). Idempotent.
    void stop();

    [[nodiscard]] const config::Config& config() const noexcept { return config_; }

private:
    Supervisor(config::Config config, std::filesystem::path file, config::LoadOptions options);

    config::Config config_;
    std::filesystem::path file_;
    config::LoadOptions options_;
    std::unique_ptr<ipc::Host> host_;
    rt::KernelFacts kernel_;
    std::vector<RunningBus> buses_;
    std::map<std::string, std::uint64_t> heartbeats_;  // by bus: a restarted bus starts again
};

}  // namespace drivebus::daemon
