// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt's command line: --check-config, --version, and a bad configuration as one line
// naming the key with exit 78, without a broker or drivebusd.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <tuple>

#include "sim_process.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;

class MqttCli : public ::testing::Test {
protected:
    MqttCli() : dir_(fs::temp_directory_path() / ("drivebus-mqtt-cli-" + std::to_string(::getpid()))) {
        fs::create_directories(dir_);
    }
    ~MqttCli() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    MqttCli(const MqttCli&) = delete;
    MqttCli& operator=(const MqttCli&) = delete;
    MqttCli(MqttCli&&) = delete;
    MqttCli& operator=(MqttCli&&) = delete;

    std::pair<int, std::string> check(const std::string& text) {
        const auto file = dir_ / "mqtt.toml";
        std::ofstream(file) << text;
        return run_program({DRIVEBUS_MQTT_PATH, "--config", file.string(), "--check-config"});
    }

    fs::path dir_;
};

TEST_F(MqttCli, TheExampleIsValid) {
    const auto [status, out] = run_program({DRIVEBUS_MQTT_PATH, "--config", DRIVEBUS_MQTT_EXAMPLE, "--check-config"});
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("valid, node board-7, broker localhost:1883, 1 bus"), std::string::npos) << out;
}

TEST_F(MqttCli, ABadKeyIsOneLineAndExit78) {
    const auto [status, out] = check("[broker]\nport = 70000\n[[bus]]\nname = \"line1\"\n");
    EXPECT_EQ(status, 78) << out;
    EXPECT_NE(out.find("broker: port"), std::string::npos) << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    const auto [missing, why] = run_program({DRIVEBUS_MQTT_PATH, "--config", (dir_ / "none.toml").string()});
    EXPECT_EQ(missing, 78) << why;
}

// Like ssh with a private key: a password file or TLS key that every user may read is refused
// before anything is sent with it, in one line naming the file and the fix.
TEST_F(MqttCli, ASecretOthersMayReadIsOneLineAndExit78) {
    const auto password = dir_ / "mqtt.password";
    const auto key = dir_ / "client.key";
    std::ofstream(password) << "s3cret\n";
    std::ofstream(key) << "not read before its mode is\n";
    const auto open_to_all =
        fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read;
    const auto owner_only = fs::perms::owner_read | fs::perms::owner_write;
    const std::string with_password =
        "[broker]\nusername = \"board\"\npassword_file = \"" + password.string() + "\"\n[[bus]]\nname = \"line1\"\n";
    const std::string with_key = "[broker.tls]\ncafile = \"" + (dir_ / "ca.pem").string() + "\"\ncertfile = \"" +
                                 (dir_ / "client.pem").string() + "\"\nkeyfile = \"" + key.string() +
                                 "\"\n[[bus]]\nname = \"line1\"\n";

    fs::permissions(password, open_to_all);
    auto [status, out] = check(with_password);
    EXPECT_EQ(status, 78) << out;
    EXPECT_NE(out.find("broker.password_file: " + password.string() + " is open to every user (mode 0644): chmod o= "),
              std::string::npos)
        << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    fs::permissions(password, owner_only);
    std::tie(status, out) = check(with_password);
    EXPECT_EQ(status, 0) << out;

    fs::permissions(key, open_to_all);
    std::tie(status, out) = check(with_key);
    EXPECT_EQ(status, 78) << out;
    EXPECT_NE(out.find("broker.tls.keyfile: " + key.string() + " is open to every user"), std::string::npos) << out;
    fs::permissions(key, owner_only);
    std::tie(status, out) = check(with_key);
    EXPECT_EQ(status, 0) << out;

    // A key that is not there is said at once, not at the first connection.
    fs::remove(key);
    std::tie(status, out) = check(with_key);
    EXPECT_EQ(status, 78) << out;
    EXPECT_NE(out.find("broker.tls.keyfile: " + key.string() + ": No such file or directory"), std::string::npos)
        << out;
}

TEST_F(MqttCli, VersionAndUsage) {
    const auto [status, out] = run_program({DRIVEBUS_MQTT_PATH, "--version"});
    EXPECT_EQ(status, 0);
    EXPECT_FALSE(out.empty());
    EXPECT_EQ(run_program({DRIVEBUS_MQTT_PATH, "--no-such-option"}).first, 2);
}

}  // namespace
}  // namespace drivebus::test
