// SPDX-License-Identifier: Apache-2.0
// drivebusd --check-line and drivebusctl line-check on a pty, against drivebus-sim: a read of
// each drive through the bus thread, a drive that does not answer, a line another program
// holds, kernel direction on a driver without RS485 support. The same check on the kernel's
// PL011 and PL061 runs in the board stage (tests/board/guest_test.cpp).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <unistd.h>

#include "serial/port.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;

class LineCheck : public ::testing::Test {
protected:
    // The pump (ATV21) at 1 and the fan (ATV58) at 2, 19200 8N1. The pump's configuration
    // asks for the writes drivebusd makes when it comes online (F803, F870/F871).
    SimProcess sim{{"--drive", "1:atv21", "--drive", "2:atv58", "--parity", "none"}};
    fs::path dir = fs::temp_directory_path() / ("line-check-" + std::to_string(::getpid()));

    void SetUp() override {
        fs::create_directories(dir);
        ASSERT_EQ(sim.command("set 2 W450 321").rfind("ok", 0), 0U);
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    // drivebusd.toml for the sim's line; `bus` goes into [[bus]], `drives` after the two.
    fs::path config(const std::string& bus = "", const std::string& drives = "") {
        const fs::path file = dir / "drivebusd.toml";
        std::ofstream(file) << "[realtime]\nmode = \"off\"\n[[bus]]\nname = \"line1\"\ndevice = \""
                            << sim.link().string() << "\"\nparity = \"none\"\n"
                            << bus
                            << "  [[bus.drive]]\n  name = \"pump\"\n  address = 1\n  profile = \"atv21\"\n"
                               "  comm_timeout = \"10s\"\n  write_block = [\"FA00\", \"FA01\"]\n"
                               "  [[bus.drive]]\n  name = \"fan\"\n  address = 2\n  profile = \"atv58\"\n"
                            << drives;
        return file;
    }
};

TEST_F(LineCheck, ReadsEachDriveOnceThroughTheBusThread) {
    const auto [status, out] = run_program({DRIVEBUSD_PATH, "--config", config().string(), "--check-line"});
    std::printf("%s", out.c_str());
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("bus line1: " + sim.link().string() + ", 19200 8N1, direction none\n"), std::string::npos)
        << out;
    EXPECT_NE(out.find("  port: open, exclusive\n"), std::string::npos) << out;
    EXPECT_NE(out.find("  transmitter empty (TIOCSERGETLSR): not reported by the driver"), std::string::npos) << out;
    EXPECT_NE(out.find("  driver enable: none (the adapter switches by itself)\n"), std::string::npos) << out;
    // FD01 is the simulated drive's own status word.
    EXPECT_TRUE(std::regex_search(out, std::regex(R"(  drive pump \(address 1, atv21\): FD01 = 0x[0-9a-f]{4} \(\d+\), )"
                                                  R"(the reply in \d+\.\d ms, 1 attempt\n)")))
        << out;
    EXPECT_NE(out.find("  drive fan (address 2, atv58): W450 = 0x0141 (321), the reply in "), std::string::npos) << out;
    // Every request answered, nothing broken on the line.
    EXPECT_TRUE(std::regex_search(out, std::regex(R"(\): (\d+) requests, \1 replies, 0 time-outs, 0 CRC errors, )")))
        << out;
    EXPECT_NE(out.find("  2 of 2 drives answered\nbus line1: ok\n"), std::string::npos) << out;
    // Read-only: none of the set-up writes drivebusd makes when a drive comes online.
    EXPECT_EQ(sim.command("writes 1"), "ok");
    EXPECT_EQ(sim.command("writes 2"), "ok");
}

TEST_F(LineCheck, ADriveThatDoesNotAnswerFailsTheCheck) {
    const auto file = config("", "  [[bus.drive]]\n  name = \"ghost\"\n  address = 7\n  profile = \"atv21\"\n");
    const auto [status, out] = run_program({DRIVEBUSD_PATH, "--config", file.string(), "--check-line"});
    std::printf("%s", out.c_str());
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("  drive ghost (address 7, atv21): FD01: timeout after 3 attempts\n"), std::string::npos) << out;
    EXPECT_NE(out.find("  2 of 3 drives answered\nbus line1: FAILED\n"), std::string::npos) << out;
}

TEST_F(LineCheck, ALineInUseIsNamedAndNotTouched) {
    serial::PortOptions options;
    options.device = sim.link();
    auto held = serial::Port::open(options);
    ASSERT_TRUE(held) << held.error().message;
    const auto [status, out] = run_program({DRIVEBUSD_PATH, "--config", config().string(), "--check-line"});
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("the line check needs the line to itself (is drivebusd running? systemctl stop drivebusd)"),
              std::string::npos)
        << out;
    EXPECT_EQ(out.find("drive pump"), std::string::npos) << out;
}

// A pty has no RS485 support: without a fallback that is the configuration's (78), with one the
// line check says which it took and reads the drives.
TEST_F(LineCheck, KernelDirectionWithoutRs485Support) {
    const auto [refused, refused_out] =
        run_program({DRIVEBUSD_PATH, "--config", config("direction = \"kernel\"\n").string(), "--check-line"});
    EXPECT_EQ(refused, 78) << refused_out;
    EXPECT_NE(refused_out.find(": the driver has no RS485 support (TIOCGRS485: Inappropriate ioctl for device); "
                               "set kernel_fallback = \"rts\" or \"none\", or another direction\n"),
              std::string::npos)
        << refused_out;
    const auto [fell_back, out] =
        run_program({DRIVEBUSD_PATH, "--config",
                     config("direction = \"kernel\"\nkernel_fallback = \"none\"\n").string(), "--check-line"});
    EXPECT_EQ(fell_back, 0) << out;
    EXPECT_NE(out.find("  driver enable: the driver has no RS485 support; kernel_fallback = \"none\"\n"),
              std::string::npos)
        << out;
}

// drivebusctl line-check runs drivebusd's (DRIVEBUSD: the build tree's); --bus picks one.
TEST_F(LineCheck, DrivebusctlRunsDrivebusdsCheck) {
    ::setenv("DRIVEBUSD", DRIVEBUSD_PATH, 1);  // NOLINT(concurrency-mt-unsafe)
    const auto [status, out] =
        run_program({DRIVEBUSCTL_PATH, "--bus", "line1", "line-check", "--config", config().string()});
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("  2 of 2 drives answered\nbus line1: ok\n"), std::string::npos) << out;
    const auto [unknown, unknown_out] =
        run_program({DRIVEBUSCTL_PATH, "--bus", "line9", "line-check", "--config", config().string()});
    EXPECT_EQ(unknown, 78) << unknown_out;
    EXPECT_NE(unknown_out.find("no bus 'line9' in the configuration (there are line1)"), std::string::npos)
        << unknown_out;
    ::setenv("DRIVEBUSD", (dir / "no-drivebusd").c_str(), 1);  // NOLINT(concurrency-mt-unsafe)
    const auto [missing, missing_out] = run_program({DRIVEBUSCTL_PATH, "line-check", "--config", config().string()});
    ::unsetenv("DRIVEBUSD");  // NOLINT(concurrency-mt-unsafe)
    EXPECT_EQ(missing, 5) << missing_out;
    EXPECT_NE(missing_out.find("cannot run " + (dir / "no-drivebusd").string() + ": No such file or directory"),
              std::string::npos)
        << missing_out;
}

}  // namespace
}  // namespace drivebus::test
