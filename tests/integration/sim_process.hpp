// SPDX-License-Identifier: Apache-2.0
// Test harness: drivebus-sim as a child process on a pty, and a minimal master on the other
// side. Every wait is for a condition, with a deadline.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rtu/framer.hpp"
#include "rtu/pdu.hpp"
#include "rtu/timing.hpp"
#include "sys/posix.hpp"

namespace drivebus::test {

// Polls `condition` until it holds or `timeout` passes.
bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout);

class SimProcess {
public:
    // Starts drivebus-sim with a pty link and a control socket in a fresh directory (or in
    // `dir`, to stand in for a device that comes back), plus `args`, and waits until both exist.
    // When `args` name a --device, the simulator opens that tty instead of making a pty, and
    // link() is that device.
    explicit SimProcess(std::vector<std::string> args, std::optional<std::filesystem::path> dir = std::nullopt);
    ~SimProcess();
    SimProcess(const SimProcess&) = delete;
    SimProcess& operator=(const SimProcess&) = delete;
    SimProcess(SimProcess&&) = delete;
    SimProcess& operator=(SimProcess&&) = delete;

    [[nodiscard]] const std::filesystem::path& link() const noexcept { return link_; }
    // Its control socket (a line in, a line back), for programs that command it themselves.
    [[nodiscard]] const std::filesystem::path& control() const noexcept { return control_; }
    // Sends one control command and returns the answer line.
    [[nodiscard]] std::string command(const std::string& line) const;
    // The Altivar 21 at `address` as a drive commissioned before: F875 onwards hold `selectors`
    // and are in effect (written, then the drive switched off and on, guide section 6). Throws
    // when the simulator refuses.
    void commission_read_block(int address, const std::vector<int>& selectors) const;
    // SIGTERM, then waits for the exit; returns the exit status (or -1 on a signal).
    int stop();
    [[nodiscard]] std::string output() const;  // what it wrote to stderr

private:
    std::filesystem::path dir_;
    std::filesystem::path link_;
    std::filesystem::path control_;
    std::filesystem::path log_;
    int pid_ = -1;
    bool owns_dir_ = true;
};

// This test process's own state directory (a temporary directory, removed at exit), made on
// first use and put in DRIVEBUS_STATE_DIR, so that every drivebusd the process starts keeps its
// lease record there unless its configuration names a state_dir. Every spawn here calls it;
// a harness that forks and execs drivebusd by itself must call it first.
const std::filesystem::path& own_state_dir();

// Any program as a child process, its output in a file. Stopped (SIGTERM) when it goes.
class Child {
public:
    explicit Child(std::vector<std::string> argv);
    ~Child();
    Child(const Child&) = delete;
    Child& operator=(const Child&) = delete;
    Child(Child&&) = delete;
    Child& operator=(Child&&) = delete;
    int stop();
    [[nodiscard]] std::string output() const;
    [[nodiscard]] int pid() const noexcept { return pid_; }

private:
    std::filesystem::path dir_;
    std::filesystem::path log_;
    int pid_ = -1;
};

// Whether an iceoryx RouDi answers on /tmp/roudi (one runs on this machine).
bool roudi_answers();
// Whether no RouDi is around at all: none answers on /tmp/roudi and none holds iceoryx's lock
// (a RouDi that is stopping closes its socket before it lets the lock go, and a drivebusd
// started in between refuses to start).
bool roudi_gone();

// Runs a program to completion (`limit` at most: then killed); returns its exit status and output.
std::pair<int, std::string> run_program(const std::vector<std::string>& argv,
                                        std::chrono::seconds limit = std::chrono::seconds(10));

// Runs drivebus-sim to completion with `args` (for argument errors); returns its exit status
// and stderr.
std::pair<int, std::string> run_sim(const std::vector<std::string>& args);

struct Reception {
    rtu::Instant written{};                // just before the request's write()
    std::vector<std::uint8_t> bytes;       // everything read, in order
    std::vector<rtu::Instant> byte_times;  // read time of each byte
    // What the master's framer made of the bytes (its timestamps include this process's
    // wake-up delays, which a pty adds and a UART would not):
    std::optional<rtu::Frame> reply;       // the reply, if one was framed
    std::vector<rtu::Frame> other_frames;  // good frames that are not that reply (an echo)
    std::vector<rtu::DiscardedFrame> discarded;
    // The reply found in the bytes themselves: the last bytes that decode as a reply to the
    // request, and where they start.
    std::optional<rtu::ResponseAdu> decoded;
    std::size_t decoded_at = 0;
};

// A master on the pty: raw termios, plain bytes, a framer expecting each reply.
class TestMaster {
public:
    TestMaster(const std::filesystem::path& device, const rtu::LineFormat& format);

    // Sends `request` (pre-encoded bytes) and reads until a reply to `expect` is framed, or
    // `timeout` passes (then `reply` is empty).
    Reception transact(const std::vector<std::uint8_t>& request, const rtu::RequestAdu& expect,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(1000));
    // Encodes `request` with the spec's limits and transacts.
    Reception transact(const rtu::RequestAdu& request,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(1000));
    // Waits until t3.5 has passed since the last byte (the line is free).
    void wait_silence();

    [[nodiscard]] const rtu::CharacterTiming& timing() const noexcept { return timing_; }

private:
    sys::UniqueFd fd_;
    rtu::CharacterTiming timing_;
    rtu::Framer framer_;
};

}  // namespace drivebus::test
