// SPDX-License-Identifier: Apache-2.0
// The drive's own Modbus time-out, with processes: drivebusd against drivebus-sim's Altivar 21.
// A pump whose F803 is 0 (off) is warned about in drivebusd's log and shown as off by
// drivebusctl; a configured comm_timeout is written to the drive when it comes online.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim_process.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class CommTimeoutProcess : public ::testing::Test {
protected:
    fs::path dir = fs::temp_directory_path() / ("drivebusd-timeout-" + std::to_string(::getpid()));
    void SetUp() override {
        fs::create_directories(dir);
        // A daemon stopped just before may take a moment to take its RouDi with it.
        if (!wait_until([] { return roudi_gone(); }, 5s)) {
            GTEST_SKIP() << "a RouDi runs already: drivebusd would join it";
        }
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    // The configuration of one pump polled every 100 ms on the simulator's line, plus `drive_keys`.
    fs::path config(const SimProcess& sim, const std::string& drive_keys = {}) const {
        const fs::path file = dir / "drivebusd.toml";
        std::ofstream(file) << "[realtime]\nmode = \"off\"\n[[bus]]\nname = \"line1\"\ndevice = \""
                            << sim.link().string()
                            << "\"\nparity = \"none\"\n  [[bus.drive]]\n  name = \"pump\"\n  address = 1\n"
                               "  profile = \"atv21\"\n"
                            << drive_keys << "\n    [[bus.drive.poll]]\n    registers = [\"FD00\"]\n"
                            << "    period = \"100ms\"\n";
        return file;
    }
};

TEST_F(CommTimeoutProcess, APumpWithItsTimeOutOffIsWarnedAboutAndListedOff) {
    SimProcess sim({"--drive", "1:atv21", "--set", "1:F803=0", "--set", "1:F603=1"});
    Child daemon({DRIVEBUSD_PATH, "--config", config(sim).string()});
    const std::string warning =
        "warning: bus line1 drive pump: Modbus time-out F803 = 0 (off); on a time-out: F603 = 1 (Deceleration "
        "stop (Err5)): off, so if the line or drivebusd dies the drive runs on at its last command";
    ASSERT_TRUE(wait_until([&] { return daemon.output().find(warning) != std::string::npos; }, 10s)) << daemon.output();
    std::string listed;
    EXPECT_TRUE(wait_until(
        [&] {
            listed = run_program({DRIVEBUSCTL_PATH, "--bus", "line1", "--json", "list"}).second;
            return listed.find(R"("comm_timeout":{"state":"read","verdict":"off","timeout_ms":0})") !=
                   std::string::npos;
        },
        10s))
        << listed;
    const auto [status, text] = run_program({DRIVEBUSCTL_PATH, "--bus", "line1", "status", "pump"});
    EXPECT_EQ(status, 0) << text;
    EXPECT_NE(text.find("time-out  F803 = off; when it fires: F603 = 1"), std::string::npos) << text;
    EXPECT_NE(text.find("OFF: if the line or drivebusd dies, the drive runs on"), std::string::npos) << text;
    EXPECT_EQ(daemon.stop(), 0) << daemon.output();
    // Once per drive per start.
    const auto out = daemon.output();
    EXPECT_EQ(out.find(warning), out.rfind(warning)) << out;
}

TEST_F(CommTimeoutProcess, AConfiguredTimeOutIsWrittenWhenThePumpComesOnline) {
    SimProcess sim({"--drive", "1:atv21"});  // factory F803: 3 s
    ASSERT_EQ(sim.command("get 1 F803"), "ok 3");
    Child daemon({DRIVEBUSD_PATH, "--config", config(sim, "  comm_timeout = \"5s\"\n").string()});
    EXPECT_TRUE(wait_until([&] { return sim.command("get 1 F803") == "ok 5"; }, 10s)) << daemon.output();
    EXPECT_TRUE(wait_until(
        [&] {
            return daemon.output().find(
                       "bus line1 drive pump: Modbus time-out F803 = 5 (5 s), written as configured") !=
                   std::string::npos;
        },
        10s))
        << daemon.output();
    EXPECT_EQ(daemon.stop(), 0) << daemon.output();
}

}  // namespace
}  // namespace drivebus::test
