// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt end to end: a real mosquitto broker on a loopback port, drivebus-sim and
// drivebusd (the Stack), and the bridge as a process. Every wait is for a condition, with a
// deadline. One RouDi per machine: RESOURCE_LOCK iceoryx.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "bridge_fixture.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

TEST_F(MqttBridge, RetainedStateMatchesTheSimulator) {
    start_bridge();
    ASSERT_TRUE(watcher_.wait(
        topic("status"), [](const Message& m) { return m.payload == "online"; }, 20s))
        << bridge_output();
    const auto state = online_state(20s);
    ASSERT_TRUE(state) << bridge_output();
    EXPECT_EQ((*state)["registers"]["FA01"]["raw"].get<int>(), stack_.sim_register(1, "FA01"));
    EXPECT_EQ((*state)["registers"]["FA01"]["unit"], "Hz");
    EXPECT_TRUE((*state)["altivar"].is_object());
    // A subscriber that comes later gets the retained state at once (mosquitto_sub).
    const auto [status, out] = mosquitto_sub_one(broker_.port(), drive_topic("pump", "state"));
    ASSERT_EQ(status, 0) << out;
    const auto retained = Json::parse(out, nullptr, false);
    ASSERT_TRUE(retained.is_object()) << out;
    EXPECT_EQ(retained["drive"], "pump");
    EXPECT_EQ(retained["registers"]["FA01"]["raw"].get<int>(), stack_.sim_register(1, "FA01"));
    // The fan is published too, and the bus status.
    EXPECT_TRUE(watcher_.wait(drive_topic("fan", "state"), [](const Message&) { return true; }, 20s));
    const auto bus = watcher_.wait(
        topic(stack_.bus() + "/status"), [](const Message& m) { return parsed(m).value("up", false); }, 20s);
    ASSERT_TRUE(bus) << bridge_output();
    EXPECT_EQ(parsed(*bus)["drivebusd"], "running");
}

TEST_F(MqttBridge, ACommandReachesTheDriveAndItsResultComesBack) {
    start_bridge();
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    const auto [status, out] =
        mosquitto_pub(broker_.port(), drive_topic("pump", "set"), R"({"id": "c-1", "frequency": 40, "verb": "run"})");
    ASSERT_EQ(status, 0) << out;
    const auto r = result("pump", "c-1", 20s);
    ASSERT_TRUE(r) << bridge_output();
    EXPECT_EQ((*r)["ok"], true) << r->dump();
    EXPECT_EQ(stack_.sim_register(1, "FA01"), 4000);
    EXPECT_EQ(stack_.sim_register(1, "FA00"), kRunForward);
    // The state shows the bridge holding the lease.
    const auto held = watcher_.wait(
        drive_topic("pump", "state"), [](const Message& m) { return parsed(m)["lease"].value("state", "") == "held"; },
        20s);
    ASSERT_TRUE(held);
    EXPECT_EQ(parsed(*held)["lease"]["holder"].get<std::string>().rfind("drivebus-mqtt", 0), 0U) << held->payload;
}

TEST_F(MqttBridge, HostileCommandsGetAResultAndNoCrash) {
    start_bridge("[limits]\ncommand_queue = 4\nmax_payload = 1024\n");
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    // Malformed JSON: a result with no id (there is none to echo) saying so.
    const std::size_t from = watcher_.count();
    ASSERT_TRUE(watcher_.publish(drive_topic("pump", "set"), "{\"id\": \"x\", "));
    const auto malformed = watcher_.wait(
        drive_topic("pump", "result"), [](const Message& m) { return parsed(m).value("reason", "") == "malformed"; },
        20s, from);
    ASSERT_TRUE(malformed) << bridge_output();
    EXPECT_TRUE(parsed(*malformed)["id"].is_null());
    // Too large: refused unread.
    ASSERT_TRUE(watcher_.publish(drive_topic("pump", "set"), std::string(200000, '{')));
    EXPECT_TRUE(watcher_.wait(
        drive_topic("pump", "result"), [](const Message& m) { return parsed(m).value("reason", "") == "too_large"; },
        20s, from));
    // Unknown drive and register.
    ASSERT_TRUE(watcher_.publish(drive_topic("nosuch", "set"), R"({"id": "u", "verb": "stop"})"));
    const auto unknown = result("nosuch", "u", 20s);
    ASSERT_TRUE(unknown);
    EXPECT_EQ((*unknown)["reason"], "unknown_drive");
    ASSERT_TRUE(watcher_.publish(drive_topic("pump", "set"), R"({"id": "r", "registers": {"ZZ99": 1}})"));
    const auto bad_register = result("pump", "r", 20s);
    ASSERT_TRUE(bad_register);
    EXPECT_EQ((*bad_register)["reason"], "invalid");
    // A flood: commands beyond the queue are refused as busy at once (results beyond the QoS 1
    // window are dropped and counted), nothing grows, and the bridge still works after it.
    for (int i = 0; i < 300; ++i) {
        watcher_.publish(drive_topic("pump", "set"),
                         Json{{"id", "f" + std::to_string(i)}, {"frequency", 10 + i % 30}}.dump());
    }
    const auto busy = watcher_.wait(
        drive_topic("pump", "result"), [](const Message& m) { return parsed(m).value("reason", "") == "busy"; }, 20s,
        from);
    EXPECT_TRUE(busy) << "a flood of 300 against a queue of 4 refused none";
    // Once the queue has drained, a command is carried out again.
    std::optional<Json> last;
    ASSERT_TRUE(wait_until(
        [&, n = 0]() mutable {
            const std::string id = "last-" + std::to_string(n++);
            watcher_.publish(drive_topic("pump", "set"), Json{{"id", id}, {"frequency", 25}}.dump());
            last = result("pump", id, 5s);
            return last && (*last)["ok"] == true;
        },
        30s))
        << (last ? last->dump() : std::string("no result")) << bridge_output();
    EXPECT_EQ(stack_.sim_register(1, "FA01"), 2500);
    EXPECT_EQ(::kill(bridge_->pid(), 0), 0);
}

TEST_F(MqttBridge, KilledTheBridgeLeavesItsWillAndTheDriveReachesItsFallback) {
    start_bridge();
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    ASSERT_EQ(
        mosquitto_pub(broker_.port(), drive_topic("pump", "set"), R"({"id": "go", "frequency": 30, "verb": "run"})")
            .first,
        0);
    const auto r = result("pump", "go", 20s);
    ASSERT_TRUE(r && (*r)["ok"] == true) << bridge_output();
    ASSERT_EQ(stack_.sim_register(1, "FA00"), kRunForward);
    const std::size_t from = watcher_.count();
    const auto killed = std::chrono::steady_clock::now();
    ASSERT_EQ(::kill(bridge_->pid(), SIGKILL), 0);
    EXPECT_TRUE(watcher_.wait(topic("status"), [](const Message& m) { return m.payload == "offline"; }, 20s, from));
    // The lease (1 s) runs out without the bridge's renewals: drivebusd writes the ramp stop.
    ASSERT_TRUE(wait_until([&] { return stack_.sim_register(1, "FA00") == kStop; }, 20s));
    const auto took = std::chrono::steady_clock::now() - killed;
    EXPECT_LT(took, 3s) << "the fallback came " << std::chrono::duration_cast<std::chrono::milliseconds>(took).count()
                        << " ms after the bridge died, with a lease of 1 s";
}

TEST_F(MqttBridge, ReconnectsAndRepublishesAfterABrokerRestart) {
    start_bridge();
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    broker_.stop();
    broker_.start();  // no persistence: the retained messages are gone with the old broker
    const auto restarted = std::chrono::steady_clock::now();
    Watcher fresh(broker_.port(), "drivebus/" + node_ + "/#");
    EXPECT_TRUE(fresh.wait(
        topic("status"), [](const Message& m) { return m.payload == "online"; }, 20s))
        << bridge_output();
    EXPECT_TRUE(fresh.wait(
        drive_topic("pump", "state"), [](const Message& m) { return parsed(m).is_object(); }, 20s))
        << bridge_output();
    EXPECT_LT(std::chrono::steady_clock::now() - restarted, 5s);
}

TEST_F(MqttBridge, BrokerDownAtStartIsRetriedAndLoggedOnce) {
    broker_.stop();
    start_bridge({}, true);
    // Several attempts (100 ms doubling to 1 s) go by, each a debug line: one warning.
    ASSERT_TRUE(wait_until([&] { return bridge_output().find("attempt 4 failed") != std::string::npos; }, 20s))
        << bridge_output();
    const auto out = bridge_output();
    EXPECT_EQ(out.find("cannot reach broker"), out.rfind("cannot reach broker")) << out;
    broker_.start();
    Watcher fresh(broker_.port(), "drivebus/" + node_ + "/#");
    EXPECT_TRUE(fresh.wait(
        topic("status"), [](const Message& m) { return m.payload == "online"; }, 20s))
        << bridge_output();
    EXPECT_TRUE(wait_until([&] { return bridge_output().find("after ") != std::string::npos; }, 5s)) << bridge_output();
}

TEST_F(MqttBridge, DrivebusdStoppedIsShownOnTheBusStatus) {
    start_bridge();
    ASSERT_TRUE(online_state(20s)) << bridge_output();
    const std::size_t from = watcher_.count();
    EXPECT_EQ(stack_.stop_daemon(), 0);
    const auto gone = watcher_.wait(
        topic(stack_.bus() + "/status"), [](const Message& m) { return parsed(m).value("drivebusd", "") != "running"; },
        15s, from);
    ASSERT_TRUE(gone) << bridge_output();
    EXPECT_EQ(parsed(*gone)["drivebusd"], "silent") << gone->payload;
    // The bridge itself stays up and online.
    EXPECT_EQ(::kill(bridge_->pid(), 0), 0);
    EXPECT_TRUE(mosquitto_sub_one(broker_.port(), topic("status")).second.find("online") != std::string::npos);
}

// TLS with a client certificate, and a username and password: a CA, a server certificate for
// 127.0.0.1 and a client certificate made with openssl, a broker that requires all of them.
class MqttBridgeTls : public ::testing::Test {
protected:
    MqttBridgeTls() : dir_(fs::temp_directory_path() / ("drivebus-mqtt-tls-" + std::to_string(::getpid()))) {
        fs::create_directories(dir_);
        const auto p = [&](const char* name) { return (dir_ / name).string(); };
        std::ofstream(p("san.cnf")) << "subjectAltName=IP:127.0.0.1\n";
        const std::vector<std::vector<std::string>> steps = {
            {"/usr/bin/openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
             "-keyout", p("ca.key"), "-out", p("ca.pem"), "-days", "2", "-subj", "/CN=drivebus test CA"},
            {"/usr/bin/openssl", "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
             "-keyout", p("server.key"), "-out", p("server.csr"), "-subj", "/CN=127.0.0.1"},
            {"/usr/bin/openssl", "x509", "-req", "-in", p("server.csr"), "-CA", p("ca.pem"), "-CAkey", p("ca.key"),
             "-CAcreateserial", "-out", p("server.pem"), "-days", "2", "-extfile", p("san.cnf")},
            {"/usr/bin/openssl", "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
             "-keyout", p("client.key"), "-out", p("client.csr"), "-subj", "/CN=board"},
            {"/usr/bin/openssl", "x509", "-req", "-in", p("client.csr"), "-CA", p("ca.pem"), "-CAkey", p("ca.key"),
             "-CAcreateserial", "-out", p("client.pem"), "-days", "2"},
            {MOSQUITTO_PASSWD_PATH, "-b", "-c", p("passwd"), "board", "s3cret"},
        };
        for (const auto& step : steps) {
            const auto [status, out] = run_program(step);
            if (status != 0) {
                throw std::runtime_error(step[0] + " " + step[1] + ": " + out);
            }
        }
        // mosquitto started as root runs as the user mosquitto: it must read them (test files only).
        for (const auto& entry : fs::directory_iterator(dir_)) {
            fs::permissions(entry.path(), fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                                              fs::perms::others_read);
        }
        std::ofstream(p("board.password")) << "s3cret\n";
        std::ofstream(p("wrong.password")) << "guess\n";
        // The bridge's own secrets, kept as it requires (it refuses one that others may read).
        for (const char* secret : {"client.key", "board.password", "wrong.password"}) {
            fs::permissions(p(secret), fs::perms::owner_read | fs::perms::owner_write);
        }
        broker_ = std::make_unique<Broker>(0, "cafile " + p("ca.pem") + "\ncertfile " + p("server.pem") + "\nkeyfile " +
                                                  p("server.key") +
                                                  "\nrequire_certificate true\nallow_anonymous false\n"
                                                  "password_file " +
                                                  p("passwd") + "\n");
    }
    ~MqttBridgeTls() override {
        bridge_.reset();
        broker_.reset();
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    MqttBridgeTls(const MqttBridgeTls&) = delete;
    MqttBridgeTls& operator=(const MqttBridgeTls&) = delete;
    MqttBridgeTls(MqttBridgeTls&&) = delete;
    MqttBridgeTls& operator=(MqttBridgeTls&&) = delete;

    void start_bridge(const std::string& password_file) {
        const auto config = dir_ / "mqtt.toml";
        std::ofstream(config) << "node = \"tls\"\n[broker]\nhost = \"127.0.0.1\"\nport = " << broker_->port()
                              << "\nusername = \"board\"\npassword_file = \"" << (dir_ / password_file).string()
                              << "\"\nreconnect_min = \"100ms\"\nreconnect_max = \"500ms\"\n[broker.tls]\ncafile = \""
                              << (dir_ / "ca.pem").string() << "\"\ncertfile = \"" << (dir_ / "client.pem").string()
                              << "\"\nkeyfile = \"" << (dir_ / "client.key").string()
                              << "\"\n[[bus]]\nname = \"nosuchbus\"\n";
        bridge_ = std::make_unique<Child>(std::vector<std::string>{DRIVEBUS_MQTT_PATH, "--config", config.string()});
    }

    // The retained node status, read over TLS with the client certificate.
    std::pair<int, std::string> node_status() {
        return run_program({MOSQUITTO_SUB_PATH,
                            "-h",
                            "127.0.0.1",
                            "-p",
                            std::to_string(broker_->port()),
                            "--cafile",
                            (dir_ / "ca.pem").string(),
                            "--cert",
                            (dir_ / "client.pem").string(),
                            "--key",
                            (dir_ / "client.key").string(),
                            "-u",
                            "board",
                            "-P",
                            "s3cret",
                            "-t",
                            "drivebus/tls/status",
                            "-C",
                            "1",
                            "-W",
                            "3",
                            "--retained-only"});
    }

    fs::path dir_;
    std::unique_ptr<Broker> broker_;
    std::unique_ptr<Child> bridge_;
};

TEST_F(MqttBridgeTls, ConnectsWithACertificateAndAPassword) {
    start_bridge("board.password");
    ASSERT_TRUE(wait_until([&] { return bridge_->output().find("connected to broker") != std::string::npos; }, 15s))
        << bridge_->output() << broker_->output();
    std::pair<int, std::string> status;
    ASSERT_TRUE(wait_until(
        [&] {
            status = node_status();
            return status.first == 0 && status.second.find("online") != std::string::npos;
        },
        15s))
        << status.second << broker_->output();
}

TEST_F(MqttBridgeTls, AWrongPasswordIsRefusedAndRetried) {
    start_bridge("wrong.password");
    ASSERT_TRUE(wait_until([&] { return bridge_->output().find("refused the connection") != std::string::npos; }, 15s))
        << bridge_->output() << broker_->output();
    // Retried with back-off and refused each time (the broker says so), logged once.
    ASSERT_TRUE(wait_until([&] { return occurrences(broker_->output(), "not authorised") >= 3; }, 15s))
        << broker_->output();
    EXPECT_EQ(occurrences(bridge_->output(), "refused the connection"), 1U) << bridge_->output();
    EXPECT_EQ(bridge_->output().find("connected to broker"), std::string::npos) << bridge_->output();
    EXPECT_EQ(::kill(bridge_->pid(), 0), 0);
}

}  // namespace
}  // namespace drivebus::test
