// SPDX-License-Identifier: Apache-2.0
// The bridge between drivebusd (libdrivebus) and the broker: each configured bus's drives'
// snapshots become retained state messages (on change beyond the deadband, and at least every
// period), its status a retained status message; commands from the broker go through a
// bounded queue to one worker thread that carries them out with libdrivebus and publishes
// each result.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "broker_link.hpp"
#include "drivebus/client.hpp"
#include "mqtt/backoff.hpp"
#include "mqtt/config.hpp"
#include "mqtt/freshness.hpp"
#include "mqtt/payload.hpp"
#include "mqtt/topics.hpp"

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
    void work();
    void carry_out(const Job& job);
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

    mutable std::mutex mutex_;  // the wake-up, drives found, the command queue
    std::condition_variable wake_;
    bool stopping_ = false;
    bool republish_ = false;
    bool dirty_ = false;
    std::deque<Job> jobs_;
    std::condition_variable jobs_ready_;
    std::thread worker_;
    BridgeCounters counters_;
};

}  // namespace drivebus::mqtt
