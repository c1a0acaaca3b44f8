// SPDX-License-Identifier: Apache-2.0
// The whole stack in separate processes for a test: drivebus-sim on a pty (an ATV21 "pump" at
// address 1 and an ATV58 "fan" at 2), drivebusd with its embedded RouDi on that pty, and the
// bus's name for clients. iceoryx allows one RouDi per machine, so tests that build a Stack
// carry the ctest RESOURCE_LOCK "iceoryx".
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim_process.hpp"

namespace drivebus::test {

struct StackOptions {
    std::vector<std::string> sim_args;  // more drivebus-sim arguments (faults, options)
    std::string drive_extra;            // extra keys for the pump's [[bus.drive]] table
    std::string bus_extra;              // extra keys for the [[bus]] table
    std::string poll_period = "50ms";
    bool polls = true;  // false: no [[bus.drive.poll]], so only clients' requests reach the line
    bool paced = true;
    bool fan = true;  // the ATV58 at address 2
    std::string roudi = "embedded";
    // The simulated ATV21 starts as from the factory, so drivebusd writes its block selectors,
    // which it applies only after a reset (guide section 6): the stack then switches it off and
    // on, as whoever commissions a drive does, and waits until drivebusd confirms its blocks.
    // false: leave it awaiting the reset.
    bool reset_pump = true;
};

class Stack {
public:
    explicit Stack(StackOptions options = {});
    ~Stack();
    Stack(const Stack&) = delete;
    Stack& operator=(const Stack&) = delete;
    Stack(Stack&&) = delete;
    Stack& operator=(Stack&&) = delete;

    [[nodiscard]] const std::string& bus() const noexcept { return bus_; }
    [[nodiscard]] SimProcess& sim() noexcept { return *sim_; }
    [[nodiscard]] const std::filesystem::path& dir() const noexcept { return dir_; }
    [[nodiscard]] const std::filesystem::path& config() const noexcept { return config_; }
    // Requests the simulator has received so far (its `stats` counter).
    [[nodiscard]] std::uint64_t sim_requests() const;
    // A register of a simulated drive, as the simulator holds it ("FD00" or a number).
    [[nodiscard]] std::uint16_t sim_register(int address, const std::string& reg) const;
    // drivebusd's output so far.
    [[nodiscard]] std::string daemon_output() const;
    [[nodiscard]] int daemon_pid() const noexcept { return daemon_->pid(); }
    // Stops drivebusd (SIGTERM) and returns its exit status.
    int stop_daemon();
    // Kills drivebusd (SIGKILL), as a crash would, and waits until it is gone.
    void kill_daemon();
    // Starts drivebusd again on the same configuration, once the last one's RouDi is gone, and
    // waits until it runs.
    void start_daemon();
    // Where drivebusd keeps its lease record (state_dir).
    [[nodiscard]] std::filesystem::path state_dir() const { return dir_ / "state"; }
    // Switches the simulated pump off and on, silent meanwhile until drivebusd has found it
    // absent; then waits until drivebusd has confirmed its set-up again.
    void power_cycle_pump();
    // The configuration text drivebusd was started with.
    [[nodiscard]] std::string config_text() const;

private:
    // Waits until drivebusd has said `times` times that the pump's set-up holds.
    void wait_for_setup(std::size_t times) const;

    std::filesystem::path dir_;
    std::filesystem::path config_;
    std::string bus_;
    std::unique_ptr<SimProcess> sim_;
    std::unique_ptr<Child> daemon_;
};

}  // namespace drivebus::test
