// SPDX-License-Identifier: Apache-2.0
// A real mosquitto broker for a test, on a free loopback port, and an MQTT client in the test
// (libmosquitto) that records what it receives. Tests fail, not skip, without mosquitto.
#pragma once

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "sim_process.hpp"

struct mosquitto;
struct mosquitto_message;

namespace drivebus::test {

class Broker {
public:
    // Starts mosquitto on a free port of 127.0.0.1 (or on `port`), and waits until it accepts.
    // `extra`: more lines of its configuration (TLS, authentication).
    explicit Broker(int port = 0, const std::string& extra = {});
    ~Broker();
    Broker(const Broker&) = delete;
    Broker& operator=(const Broker&) = delete;
    Broker(Broker&&) = delete;
    Broker& operator=(Broker&&) = delete;

    [[nodiscard]] int port() const noexcept { return port_; }
    [[nodiscard]] std::string output() const { return process_ ? process_->output() : std::string(); }
    // Stops it (SIGTERM, waits for the exit).
    void stop();
    // Starts it again on the same port.
    void start();

private:
    std::filesystem::path dir_;
    int port_ = 0;
    std::unique_ptr<Child> process_;
};

struct Message {
    std::string topic;
    std::string payload;
    bool retained = false;
};

// An MQTT client that subscribes to `filter` and keeps every message (reconnects by itself).
class Watcher {
public:
    Watcher(int port, const std::string& filter);
    ~Watcher();
    Watcher(const Watcher&) = delete;
    Watcher& operator=(const Watcher&) = delete;
    Watcher(Watcher&&) = delete;
    Watcher& operator=(Watcher&&) = delete;

    // The first message on `topic` received after `from` (an index into messages) for which
    // `accept` holds, waiting up to `timeout`.
    std::optional<Message> wait(const std::string& topic, const std::function<bool(const Message&)>& accept,
                                std::chrono::milliseconds timeout, std::size_t from = 0);
    [[nodiscard]] std::size_t count() const;
    [[nodiscard]] std::vector<Message> messages() const;
    // QoS 1 publish; false when libmosquitto refused it.
    bool publish(const std::string& topic, const std::string& payload, int qos = 1);

private:
    static void on_connect(mosquitto* m, void* self, int rc);
    static void on_message(mosquitto* m, void* self, const mosquitto_message* message);

    std::string filter_;
    mosquitto* mosq_ = nullptr;
    mutable std::mutex mutex_;
    std::condition_variable arrived_;
    std::vector<Message> messages_;
};

// mosquitto_pub / mosquitto_sub, to the broker on `port`: exit status and output.
std::pair<int, std::string> mosquitto_pub(int port, const std::string& topic, const std::string& payload,
                                          bool retain = false);
std::pair<int, std::string> mosquitto_sub_one(int port, const std::string& topic);

}  // namespace drivebus::test
