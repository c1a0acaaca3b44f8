// SPDX-License-Identifier: Apache-2.0
// The bridge end to end, for the tests that share it: a real mosquitto broker on a loopback
// port, drivebus-sim and drivebusd (the Stack), and drivebus-mqtt as a process.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "broker.hpp"
#include "stack.hpp"

namespace drivebus::test {

using Json = nlohmann::json;

inline constexpr std::uint16_t kRunForward = 0xC400;  // profiles/atv21.toml [control]
inline constexpr std::uint16_t kStop = 0xC000;

inline StackOptions stack_options() {
    StackOptions o;
    o.drive_extra = "  lease = \"1s\"\n  fallback = \"stop\"\n";
    return o;
}

inline std::size_t occurrences(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) {
        ++n;
    }
    return n;
}

inline Json parsed(const Message& m) {
    return Json::parse(m.payload, nullptr, false);
}

class MqttBridge : public ::testing::Test {
protected:
    MqttBridge()
        : stack_(stack_options()),
          broker_(),
          node_("t" + std::to_string(::getpid())),
          watcher_(broker_.port(), "drivebus/" + node_ + "/#") {}

    // Starts the bridge with commands enabled for the pump only.
    void start_bridge(const std::string& extra_limits = {}, bool verbose = false) {
        config_ = stack_.dir() / "mqtt.toml";
        std::ofstream(config_) << "node = \"" << node_
                               << "\"\n[broker]\nhost = \"127.0.0.1\"\nport = " << broker_.port()
                               << "\nreconnect_min = \"100ms\"\nreconnect_max = \"1s\"\nkeepalive = \"5s\"\n"
                               << extra_limits << "[[bus]]\nname = \"" << stack_.bus()
                               << "\"\nperiod = \"2s\"\n  [[bus.drive]]\n  name = \"pump\"\n  commands = true\n";
        std::vector<std::string> argv{DRIVEBUS_MQTT_PATH, "--config", config_.string()};
        if (verbose) {
            argv.emplace_back("--verbose");
        }
        bridge_ = std::make_unique<Child>(argv);
    }

    [[nodiscard]] std::string topic(const std::string& rest) const { return "drivebus/" + node_ + "/" + rest; }
    [[nodiscard]] std::string drive_topic(const std::string& drive, const std::string& what) const {
        return topic(stack_.bus() + "/" + drive + "/" + what);
    }

    // The pump's state, online, with FA01 read.
    std::optional<Json> online_state(std::chrono::milliseconds timeout, std::size_t from = 0) {
        const auto m = watcher_.wait(
            drive_topic("pump", "state"),
            [](const Message& msg) {
                const auto j = parsed(msg);
                return j.is_object() && j.value("health", "") == "online" && j["registers"].contains("FA01") &&
                       j["registers"]["FA01"]["raw"].is_number();
            },
            timeout, from);
        if (!m) {
            return std::nullopt;
        }
        return parsed(*m);
    }

    std::optional<Json> result(const std::string& drive, const Json& id, std::chrono::milliseconds timeout) {
        const auto m = watcher_.wait(
            drive_topic(drive, "result"), [&](const Message& msg) { return parsed(msg).value("id", Json()) == id; },
            timeout);
        if (!m) {
            return std::nullopt;
        }
        return parsed(*m);
    }

    std::string bridge_output() const { return bridge_ ? bridge_->output() : std::string(); }

    Stack stack_;
    Broker broker_;
    std::string node_;
    Watcher watcher_;
    std::filesystem::path config_;
    std::unique_ptr<Child> bridge_;
};

}  // namespace drivebus::test
