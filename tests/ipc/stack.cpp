// SPDX-License-Identifier: Apache-2.0
#include "stack.hpp"

#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

std::uint64_t field(const std::string& text, const std::string& key) {
    const auto at = text.find(key + "=");
    if (at == std::string::npos) {
        throw std::runtime_error("no " + key + " in: " + text);
    }
    return std::stoull(text.substr(at + key.size() + 1));
}

}  // namespace

Stack::Stack(StackOptions options) {
    dir_ = fs::temp_directory_path() / ("drivebus-stack-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // Another drivebusd (a test of another build, a benchmark) may still be stopping: give it time.
    if (!wait_until([] { return roudi_gone(); }, 60s)) {
        throw std::runtime_error("a RouDi already runs on this machine (/tmp/roudi): stop it before these tests");
    }
    bus_ = "t" + std::to_string(::getpid());
    std::vector<std::string> args = {"--drive", "1:atv21"};
    if (options.fan) {
        args.insert(args.end(), {"--drive", "2:atv58"});
    }
    if (!options.paced) {
        args.emplace_back("--no-pace");
    }
    args.insert(args.end(), options.sim_args.begin(), options.sim_args.end());
    fs::create_directories(dir_ / "sim");
    sim_ = std::make_unique<SimProcess>(args, dir_ / "sim");
    config_ = dir_ / "drivebusd.toml";
    const std::string pump_polls =
        "\n    [[bus.drive.poll]]\n    registers = [\"FD00\", \"FD01\", \"FE03\", \"FE05\", "
        "\"FC91\"]\n    indirect = true\n    period = \"" +
        options.poll_period +
        "\"\n    [[bus.drive.poll]]\n    name = \"slow\"\n    registers = [\"FA01\", "
        "\"FC90\"]\n    period = \"200ms\"\n";
    const std::string fan_polls =
        "    [[bus.drive.poll]]\n    registers = [\"W450\", \"W451\", \"W452\"]\n    period = \"100ms\"\n";
    std::ofstream(config_) << "[realtime]\nmode = \"off\"\nlock_memory = false\n"
                              "[ipc]\nroudi = \""
                           << options.roudi
                           << "\"\n"
                              "[[bus]]\nname = \""
                           << bus_ << "\"\ndevice = \"" << sim_->link().string()
                           << "\"\nparity = \"none\"\nresponse_timeout = \"100ms\"\nretries = 3\nstate_dir = \""
                           << (dir_ / "state").string() << "\"\n"
                           << options.bus_extra
                           << "  [[bus.drive]]\n  name = \"pump\"\n  address = 1\n  profile = \"atv21\"\n"
                           << options.drive_extra << (options.polls ? pump_polls : std::string("\n"));
    if (options.fan) {
        std::ofstream(config_, std::ios::app)
            << "  [[bus.drive]]\n  name = \"fan\"\n  address = 2\n  profile = \"atv58\"\n"
            << (options.polls ? fan_polls : std::string());
    }
    start_daemon();
    if (options.reset_pump && config_text().find("indirect = true") != std::string::npos) {
        if (!wait_until([&] { return daemon_->output().find("drive pump: awaiting a reset") != std::string::npos; },
                        20s)) {
            throw std::runtime_error("drivebusd never said the pump awaits a reset: " + daemon_->output());
        }
        // The read block confirms the reset: a power cycle without silence is enough.
        if (const auto answer = sim_->command("power 1"); answer != "ok") {
            throw std::runtime_error("drivebus-sim: power 1: " + answer);
        }
        wait_for_setup(1);
    }
}

void Stack::wait_for_setup(std::size_t times) const {
    const std::string holds = "drive pump: its set-up holds";
    const auto count = [&] {
        const std::string out = daemon_->output();
        std::size_t n = 0;
        for (auto at = out.find(holds); at != std::string::npos; at = out.find(holds, at + 1)) {
            ++n;
        }
        return n;
    };
    if (!wait_until([&] { return count() >= times; }, 60s)) {
        throw std::runtime_error("drivebusd never confirmed the pump's set-up: " + daemon_->output());
    }
}

void Stack::power_cycle_pump() {
    const auto before = daemon_->output();
    const auto count = [](const std::string& text, const std::string& what) {
        std::size_t n = 0;
        for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) {
            ++n;
        }
        return n;
    };
    const std::string absent = "drive pump (address 1): absent";
    const std::size_t absences = count(before, absent);
    const std::size_t confirmed = count(before, "drive pump: its set-up holds");
    const auto must = [&](const std::string& line) {
        if (const auto answer = sim_->command(line); answer.rfind("ok", 0) != 0) {
            throw std::runtime_error("drivebus-sim: " + line + ": " + answer);
        }
    };
    must("fault 1 drop=1");
    if (!wait_until([&] { return count(daemon_->output(), absent) > absences; }, 30s)) {
        throw std::runtime_error("drivebusd never found the silent pump absent: " + daemon_->output());
    }
    must("power 1");
    must("clear 1");
    wait_for_setup(confirmed + 1);
}

Stack::~Stack() {
    daemon_.reset();
    sim_.reset();
    std::error_code ec;
    fs::remove_all(dir_, ec);
}

std::uint64_t Stack::sim_requests() const {
    return field(sim_->command("stats"), "requests");
}

std::uint16_t Stack::sim_register(int address, const std::string& reg) const {
    const auto reply = sim_->command("get " + std::to_string(address) + " " + reg);
    if (reply.rfind("ok ", 0) != 0) {
        throw std::runtime_error("sim get " + reg + ": " + reply);
    }
    return static_cast<std::uint16_t>(std::stoul(reply.substr(3)));
}

std::string Stack::daemon_output() const {
    return daemon_->output();
}

std::string Stack::config_text() const {
    std::ifstream in(config_);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

int Stack::stop_daemon() {
    return daemon_->stop();
}

void Stack::kill_daemon() {
    ::kill(daemon_->pid(), SIGKILL);
    (void)daemon_->stop();  // reaps it
}

void Stack::start_daemon() {
    if (!wait_until([] { return roudi_gone(); }, 60s)) {
        throw std::runtime_error("the last RouDi is still there (/tmp/roudi)");
    }
    daemon_ = std::make_unique<Child>(std::vector<std::string>{DRIVEBUSD_PATH, "--config", config_.string()});
    // Ready when drivebusd's RouDi answers and the daemon says it runs.
    if (!wait_until([&] { return roudi_answers() && daemon_->output().find("running:") != std::string::npos; }, 10s)) {
        throw std::runtime_error("drivebusd did not come up: " + daemon_->output());
    }
}

}  // namespace drivebus::test
