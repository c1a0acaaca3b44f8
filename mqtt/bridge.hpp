// SPDX-License-Identifier: Apache-2.0
// The bridge between drivebusd (libdrivebus) and the broker: each configured bus's drives'
// snapshots become retained state messages (on change beyond the deadband, and at least every
// period), its status a retained status message; commands from the broker go to the pure
// Commander (mqtt/commander.hpp), whose steps become libdrivebus requests and whose results are
// published. All of it runs on one event loop (run()): libdrivebus on Delivery::Dispatch, its
// requests answered by callback; the broker's network thread (libmosquitto's) only queues the
// messages and wakes it.
#pragma once

#include <atomic>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "broker_link.hpp"
#include "drivebus/client.hpp"
#include "mqtt/backoff.hpp"
#include "mqtt/commander.hpp"
#include "mqtt/config.hpp"
#include "mqtt/freshness.hpp"
#include "mqtt/payload.hpp"
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
    struct DriveLink;
    struct BusLink;
    // What the Commander reads of the buses: the links the loop keeps.
    class Fleet final : public Roster {
    public:
        explicit Fleet(const Bridge& bridge) : bridge_(bridge) {}
        [[nodiscard]] bool has_bus(std::string_view bus) const override;
        [[nodiscard]] std::optional<Drive> drive(std::string_view bus, std::string_view drive) const override;

    private:
        const Bridge& bridge_;
    };
    // A message on a set topic, as the network thread took it.
    struct Inbound {
        Topics::Target target;
        std::string payload;
        bool retained = false;
        WallTime received;          // the wall clock when it arrived: its sent_at is compared with this
        Clock::time_point arrived;  // the same moment on the steady clock: its wait is measured from this
    };

    void on_connected();
    void on_message(std::string_view topic, std::string_view payload, bool retained);
    // The messages the network thread queued, to the Commander.
    void take_messages();
    // Publishes the Commander's results and sends its steps to drivebusd.
    void carry(const CommanderEffects& effects);
    void wake() const { wake_.signal(); }
    void connect_bus(BusLink& bus, Clock::time_point now);
    void publish_bus(BusLink& bus, Clock::time_point now, bool force);
    void publish_drive(BusLink& bus, DriveLink& drive, Clock::time_point now, bool force);
    [[nodiscard]] Clock::time_point next_deadline(Clock::time_point now) const;
    [[nodiscard]] DriveLink* find(std::string_view bus, std::string_view drive) const;

    const Config& config_;
    Topics topics_;
    std::vector<std::unique_ptr<BusLink>> buses_;
    std::unique_ptr<BrokerLink> link_;
    Fleet fleet_{*this};
    Commander commander_;
    std::uint64_t states_published_ = 0;

    mutable std::mutex mutex_;  // the flags and the messages the network thread queued
    sys::EventFd wake_{"eventfd to wake the bridge's loop"};
    bool stopping_ = false;
    bool republish_ = false;
    std::deque<Inbound> inbox_;
};

}  // namespace drivebus::mqtt
