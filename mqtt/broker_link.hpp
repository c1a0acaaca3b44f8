// SPDX-License-Identifier: Apache-2.0
// The bridge's connection to the MQTT broker (libmosquitto): its own network thread connects,
// reconnects with back-off (the first failure logged, the rest counted), sets the last will
// ("offline", retained) and publishes the birth ("online", retained) on each connection.
// Nothing is queued while the broker is away: a publish then is dropped and counted, and the
// bridge republishes its retained state on the next connection. QoS 1 messages the broker has
// not yet acknowledged are bounded too.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_set>

#include "mqtt/backoff.hpp"
#include "mqtt/config.hpp"
#include "mqtt/ports.hpp"
#include "mqtt/topics.hpp"

struct mosquitto;
struct mosquitto_message;

namespace drivebus::mqtt {

struct LinkCounters {
    std::uint64_t connections = 0;
    std::uint64_t failed_attempts = 0;
    std::uint64_t dropped = 0;  // publishes dropped: no connection, or too many unacknowledged
};

class BrokerLink final : public Broker {
public:
    static constexpr std::size_t kMaxUnwritten = 256;

    struct Callbacks {
        std::function<void()> connected;  // on the network thread, after the birth message
        // `retained`: the broker kept it and hands it over on (re)subscription, however old it is.
        std::function<void(std::string_view topic, std::string_view payload, bool retained)> message;
    };

    BrokerLink(const Config& config, Callbacks callbacks);
    ~BrokerLink() override;

    void start();
    // Publishes "offline" (a clean disconnect does not send the will), disconnects, joins.
    void stop();

    // False when dropped: not connected, `results_in_flight` QoS 1 messages unacknowledged, or
    // (QoS 0) kMaxUnwritten messages not yet written to the socket (a broker that stopped
    // reading without closing the connection).
    bool publish(const std::string& topic, std::string_view payload, int qos, bool retain) override;
    [[nodiscard]] bool connected() const noexcept override { return connected_.load(); }
    [[nodiscard]] LinkCounters counters() const;

private:
    static void on_connect(mosquitto* m, void* self, int rc);
    static void on_disconnect(mosquitto* m, void* self, int rc);
    static void on_publish(mosquitto* m, void* self, int mid);
    static void on_message(mosquitto* m, void* self, const mosquitto_message* message);
    void run();
    bool attempt(bool first);
    void wait_for(Backoff::Duration delay);
    void say_goodbye();

    const Config& config_;
    Topics topics_;
    Callbacks callbacks_;
    mosquitto* mosq_ = nullptr;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
    std::atomic<bool> connected_{false};
    std::atomic<bool> socket_open_{false};
    std::mutex in_flight_mutex_;
    std::unordered_set<int> in_flight_;  // mids of QoS 1 messages not yet acknowledged
    std::unordered_set<int> unwritten_;  // mids of QoS 0 messages libmosquitto has not written yet
    std::atomic<std::uint64_t> dropped_{0};
    std::atomic<int> goodbye_mid_{-1};
    std::atomic<bool> goodbye_acked_{false};
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    LinkCounters counters_;  // under mutex_ (connections, failed_attempts)
    Backoff backoff_;
};

}  // namespace drivebus::mqtt
