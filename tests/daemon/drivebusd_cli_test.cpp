// drivebusd as a program: --check-config on good and bad files. Every bad configuration is
// one line naming the problem, and exit code 78; nothing is opened.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim_process.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;

struct BadConfig {
    const char* name;
    const char* text;
    const char* says;  // part of the one line it must print
};

const char* const kGood = R"(
[realtime]
mode = "off"
[[bus]]
name = "line1"
device = "/dev/ttyDOESNOTEXIST"
parity = "none"
  [[bus.drive]]
  name = "pump"
  address = 1
  profile = "atv21"
    [[bus.drive.poll]]
    registers = ["FD00"]
    period = "100ms"
)";

std::string with(std::string_view from, std::string_view to) {
    std::string text = kGood;
    const auto at = text.find(from);
    if (at == std::string::npos) {
        throw std::runtime_error("test config has no " + std::string(from));
    }
    text.replace(at, from.size(), to);
    return text;
}

class DrivebusdCli : public ::testing::Test {
protected:
    fs::path dir = fs::temp_directory_path() / ("drivebusd-cli-" + std::to_string(::getpid()));
    void SetUp() override { fs::create_directories(dir); }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    std::pair<int, std::string> check(const std::string& text) {
        const fs::path file = dir / "drivebusd.toml";
        std::ofstream(file) << text;
        return run_program({DRIVEBUSD_PATH, "--config", file.string(), "--check-config"});
    }
};

TEST_F(DrivebusdCli, AValidConfigurationChecksOutWithoutOpeningTheDevice) {
    const auto [status, out] = check(kGood);
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("valid, 1 bus, 1 drive"), std::string::npos) << out;
}

TEST_F(DrivebusdCli, TheExamplesAreValid) {
    for (const char* example : {"sim.toml", "atv21-atv58.toml", "gpio.toml"}) {
        const auto [status, out] =
            run_program({DRIVEBUSD_PATH, "--config", std::string(EXAMPLES_DIR) + "/" + example, "--check-config"});
        EXPECT_EQ(status, 0) << example << ": " << out;
    }
}

TEST_F(DrivebusdCli, BadConfigurationsAreOneLineAndExit78) {
    const std::vector<std::pair<std::string, std::string>> cases{
        {with("parity = \"none\"", "parity = \"none\"\nbaudrate = 19200"), "baudrate"},
        {with("parity = \"none\"", "parity = \"mark\""), "parity"},
        {with("parity = \"none\"", "parity = \"none\"\nbaud = 12345"), "12345"},
        {with("address = 1", "address = 248"), "248"},
        {with("profile = \"atv21\"", "profile = \"atv99\""), "atv99"},
        {with("registers = [\"FD00\"]", "registers = [\"FZ00\"]"), "FZ00"},
        {with("period = \"100ms\"", "period = \"100\""), "period"},
        {with("parity = \"none\"", "parity = \"none\"\ndirection = \"gpio\""), "gpio"},
        {with("parity = \"none\"", "parity = \"none\"\nrts_on_send = true"), "rts_on_send"},
        {with("parity = \"none\"", "parity = \"none\"\necho = \"sometimes\""), "echo"},
        {with("parity = \"none\"", "parity = \"none\"\nretries = 99"), "retries"},
        {with("mode = \"off\"", "mode = \"off\"\npriority = 150"), "priority"},
        {with("name = \"line1\"", "name = \"Line 1\""), "Line 1"},
        {"this is not toml", "drivebusd.toml"},
        {"", "bus"},
    };
    for (const auto& [text, says] : cases) {
        const auto [status, out] = check(text);
        EXPECT_EQ(status, 78) << "accepted:\n" << text << "\nprinted: " << out;
        EXPECT_NE(out.find(says), std::string::npos) << "the message does not name '" << says << "': " << out;
        EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << "not one line: " << out;
    }
}

TEST_F(DrivebusdCli, MissingFileAndBadArguments) {
    const auto [status, out] =
        run_program({DRIVEBUSD_PATH, "--config", (dir / "nope.toml").string(), "--check-config"});
    EXPECT_EQ(status, 78);
    EXPECT_NE(out.find("nope.toml"), std::string::npos) << out;
    const auto [status2, out2] = run_program({DRIVEBUSD_PATH, "--check-config"});
    EXPECT_EQ(status2, 2) << out2;
    EXPECT_NE(out2.find("--config"), std::string::npos) << out2;
}

}  // namespace
}  // namespace drivebus::test
