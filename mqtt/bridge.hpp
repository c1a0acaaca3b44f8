// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt's loop: the Relay (mqtt/relay.hpp, where every rule is) on poll(), with the
// broker on libmosquitto (broker_link.hpp) and drivebusd on libdrivebus (daemon_link.hpp).
// libdrivebus runs on Delivery::Dispatch, so its callbacks run on this loop; the broker's
// network thread (libmosquitto's) only queues the messages and wakes it.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "broker_link.hpp"
#include "daemon_link.hpp"
#include "mqtt/config.hpp"
#include "mqtt/inbox.hpp"
#include "mqtt/relay.hpp"
#include "mqtt/topics.hpp"
#include "sys/event_fd.hpp"

namespace drivebus::mqtt {

class Bridge {
public:
    explicit Bridge(const Config& config);
    ~Bridge();
    Bridge(const Bridge&) = delete;
    Bridge& operator=(const Bridge&) = delete;
    Bridge(Bridge&&) = delete;
    Bridge& operator=(Bridge&&) = delete;

    // Runs until stop(): connects the broker and the buses, publishes, takes commands.
    void run();
    void stop();

private:
    void on_connected();
    void on_message(std::string_view topic, std::string_view payload, bool retained);
    void wake() const { wake_.signal(); }

    const Config& config_;
    Topics topics_;
    std::unique_ptr<BrokerLink> link_;
    DaemonLink daemon_;
    std::unique_ptr<Relay> relay_;

    mutable std::mutex mutex_;  // the flags and the messages the network thread queued
    sys::EventFd wake_{"eventfd to wake the bridge's loop"};
    bool stopping_ = false;
    bool republish_ = false;
    Inbox inbox_;
};

}  // namespace drivebus::mqtt
