// SPDX-License-Identifier: Apache-2.0
// The bridge between drivebusd (libdrivebus) and the broker: each configured bus's drives'
// snapshots become retained state messages (on change beyond the deadband, and at least every
// period), its status a retained status message; commands from the broker go through a
// bounded queue and are carried out one at a time, each result published. All of it runs on
// one event loop (run()): libdrivebus on Delivery::Dispatch, its requests answered by callback;
// the broker's network thread (libmosquitto's) only queues and wakes it.
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
#include "mqtt/config.hpp"
#include "mqtt/freshness.hpp"
#include "mqtt/payload.hpp"
#include "mqtt/topics.hpp"
#include "sys/event_fd.hpp"

namespace drivebus::mqtt {

struct BridgeCounters {
    std::uint64_t states_published = 0;
    std::uint64_t commands = 0;
    std::uint64_t commands_refused = 0;  // malformed, not enabled, unknown drive, queue full
    std::uint64_t commands_queue_full = 0;
};

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
    struct Job {
        std::string bus;
        std::string drive;
        std::string payload;
        WallTime received;          // the wall clock when it arrived: its sent_at is compared with this
        Clock::time_point arrived;  // the same moment on the steady clock: its wait is measured from this
    };

    void on_connected();
    void on_message(std::string_view topic, std::string_view payload, bool retained);
    void refuse(const Topics::Target& target, const Json& id, std::string_view reason, std::string_view message);
    struct Running;
    // The next queued command, when none is under way.
    void start_command();
    // Carries out the command's next action, or ends it with its result.
    void step(const std::shared_ptr<Running>& r);
    void wake() const { wake_.signal(); }
    void connect_bus(BusLink& bus, Clock::time_point now);
    void publish_bus(BusLink& bus, Clock::time_point now, bool force);
    void publish_drive(BusLink& bus, DriveLink& drive, Clock::time_point now, bool force);
    [[nodiscard]] Clock::time_point next_deadline(Clock::time_point now) const;
    std::shared_ptr<DriveLink> find(std::string_view bus, std::string_view drive,
                                    const BusLink** on_bus = nullptr) const;

    const Config& config_;
    Topics topics_;
    std::vector<std::unique_ptr<BusLink>> buses_;
    std::unique_ptr<BrokerLink> link_;

    mutable std::mutex mutex_;  // the flags, drives found, the command queue
    sys::EventFd wake_{"eventfd to wake the bridge's loop"};
    bool stopping_ = false;
    bool republish_ = false;
    std::deque<Job> jobs_;
    std::shared_ptr<Running> running_;  // the command under way (the loop's thread only)
    BridgeCounters counters_;
};

}  // namespace drivebus::mqtt
