// SPDX-License-Identifier: Apache-2.0
#include "broker_link.hpp"

#include <mosquitto.h>

#include <cerrno>
#include <cstring>
#include <random>
#include <stdexcept>

#include "log/log.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

constexpr std::string_view kOnline = "online";
constexpr std::string_view kOffline = "offline";
constexpr int kLoopTimeoutMs = 100;

std::string endpoint(const BrokerConfig& b) {
    return b.host + ":" + std::to_string(b.port);
}

}  // namespace

BrokerLink::BrokerLink(const Config& config, Callbacks callbacks)
    : config_(config),
      topics_(config.node),
      callbacks_(std::move(callbacks)),
      backoff_(config.broker.reconnect_min, config.broker.reconnect_max) {
    mosquitto_lib_init();
    const auto id = config_.client_id();
    mosq_ = mosquitto_new(id.c_str(), true, this);
    if (mosq_ == nullptr) {
        throw std::runtime_error("libmosquitto: cannot create a client");
    }
    mosquitto_threaded_set(mosq_, true);
    mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
    // Each state is a message of its own: Nagle's algorithm would hold it back until the broker
    // acknowledged the previous one (tens of milliseconds with delayed ACKs).
    mosquitto_int_option(mosq_, MOSQ_OPT_TCP_NODELAY, 1);
    mosquitto_connect_callback_set(mosq_, &BrokerLink::on_connect);
    mosquitto_disconnect_callback_set(mosq_, &BrokerLink::on_disconnect);
    mosquitto_publish_callback_set(mosq_, &BrokerLink::on_publish);
    mosquitto_message_callback_set(mosq_, &BrokerLink::on_message);
    const auto status = topics_.node_status();
    if (const int rc =
            mosquitto_will_set(mosq_, status.c_str(), static_cast<int>(kOffline.size()), kOffline.data(), 1, true);
        rc != MOSQ_ERR_SUCCESS) {
        throw std::runtime_error(std::string("libmosquitto: last will: ") + mosquitto_strerror(rc));
    }
    const auto& b = config_.broker;
    if (!b.username.empty()) {
        if (const int rc = mosquitto_username_pw_set(mosq_, b.username.c_str(),
                                                     config_.password.empty() ? nullptr : config_.password.c_str());
            rc != MOSQ_ERR_SUCCESS) {
            throw std::runtime_error(std::string("libmosquitto: username: ") + mosquitto_strerror(rc));
        }
    }
    if (b.tls) {
        const auto& t = *b.tls;
        const auto cert = t.certfile.string();
        const auto key = t.keyfile.string();
        if (const int rc = mosquitto_tls_set(mosq_, t.cafile.c_str(), nullptr, cert.empty() ? nullptr : cert.c_str(),
                                             key.empty() ? nullptr : key.c_str(), nullptr);
            rc != MOSQ_ERR_SUCCESS) {
            throw std::runtime_error("broker.tls: " + std::string(mosquitto_strerror(rc)) + " (cafile " +
                                     t.cafile.string() + ")");
        }
    }
}

BrokerLink::~BrokerLink() {
    stop();
    mosquitto_destroy(mosq_);
    mosquitto_lib_cleanup();
}

void BrokerLink::start() {
    thread_ = std::thread([this] { run(); });
}

void BrokerLink::stop() {
    if (!thread_.joinable()) {
        return;
    }
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    thread_.join();
}

LinkCounters BrokerLink::counters() const {
    std::lock_guard lock(mutex_);
    auto c = counters_;
    c.dropped = dropped_.load();
    return c;
}

bool BrokerLink::publish(const std::string& topic, std::string_view payload, int qos, bool retain) {
    if (!connected_.load()) {
        ++dropped_;
        return false;
    }
    // The mid is booked under the lock before its on_publish can come (written, or acknowledged),
    // so that the sets hold exactly what is still outstanding.
    std::lock_guard lock(in_flight_mutex_);
    if (qos > 0 ? in_flight_.size() >= config_.limits.results_in_flight : unwritten_.size() >= kMaxUnwritten) {
        ++dropped_;
        return false;
    }
    int mid = 0;
    const int rc =
        mosquitto_publish(mosq_, &mid, topic.c_str(), static_cast<int>(payload.size()), payload.data(), qos, retain);
    if (rc != MOSQ_ERR_SUCCESS) {
        ++dropped_;
        return false;
    }
    (qos > 0 ? in_flight_ : unwritten_).insert(mid);
    return true;
}

void BrokerLink::on_connect(mosquitto* m, void* self, int rc) {
    auto& link = *static_cast<BrokerLink*>(self);
    if (rc != 0) {
        // Once, then counted with the other failed attempts (the loop's back-off).
        bool first = false;
        {
            std::lock_guard lock(link.mutex_);
            first = link.backoff_.failures() == 0;
        }
        if (first) {
            log::warning("broker " + endpoint(link.config_.broker) + " refused the connection: " +
                         mosquitto_connack_string(rc) + "; retrying with back-off, failures counted");
        }
        return;
    }
    const auto filter = link.topics_.set_filter();
    mosquitto_subscribe(m, nullptr, filter.c_str(), 1);
    {
        std::lock_guard lock(link.in_flight_mutex_);
        link.in_flight_.clear();
        link.unwritten_.clear();  // libmosquitto drops unsent QoS 0 messages with the connection
    }
    link.connected_ = true;
    std::uint64_t failed = 0;
    {
        std::lock_guard lock(link.mutex_);
        ++link.counters_.connections;
        failed = link.backoff_.failures();
        link.backoff_.reset();
    }
    log::notice("connected to broker " + endpoint(link.config_.broker) + " as " + link.config_.client_id() +
                (failed > 0 ? " after " + std::to_string(failed) + " failed attempts" : std::string()));
    link.publish(link.topics_.node_status(), kOnline, 1, true);
    if (link.callbacks_.connected) {
        link.callbacks_.connected();
    }
}

void BrokerLink::on_disconnect(mosquitto* /*m*/, void* self, int rc) {
    auto& link = *static_cast<BrokerLink*>(self);
    const bool was = link.connected_.exchange(false);
    if (was && !link.stopping_.load()) {
        log::warning("lost broker " + endpoint(link.config_.broker) + ": " + mosquitto_strerror(rc) +
                     "; reconnecting with back-off");
    }
}

void BrokerLink::on_publish(mosquitto* /*m*/, void* self, int mid) {
    auto& link = *static_cast<BrokerLink*>(self);
    {
        std::lock_guard lock(link.in_flight_mutex_);
        // QoS 0: written to the socket; QoS 1: acknowledged by the broker.
        link.in_flight_.erase(mid);
        link.unwritten_.erase(mid);
    }
    if (mid == link.goodbye_mid_.load()) {
        link.goodbye_acked_ = true;
    }
}

void BrokerLink::on_message(mosquitto* /*m*/, void* self, const mosquitto_message* message) {
    auto& link = *static_cast<BrokerLink*>(self);
    if (link.callbacks_.message && message->topic != nullptr) {
        link.callbacks_.message(
            message->topic,
            std::string_view(static_cast<const char*>(message->payload),
                             message->payload != nullptr ? static_cast<std::size_t>(message->payloadlen) : 0U),
            message->retain);
    }
}

bool BrokerLink::attempt(bool first) {
    const auto& b = config_.broker;
    const int keepalive = static_cast<int>(std::chrono::duration_cast<std::chrono::seconds>(b.keepalive).count());
    const int rc = first ? mosquitto_connect(mosq_, b.host.c_str(), b.port, keepalive) : mosquitto_reconnect(mosq_);
    if (rc == MOSQ_ERR_SUCCESS) {
        socket_open_ = true;
        return true;
    }
    std::uint64_t failed = 0;
    {
        std::lock_guard lock(mutex_);
        ++counters_.failed_attempts;
        failed = counters_.failed_attempts;
    }
    // Once, then counted: a broker that stays away does not fill the journal.
    if (backoff_.failures() == 0) {
        log::warning("cannot reach broker " + endpoint(b) + ": " +
                     (rc == MOSQ_ERR_ERRNO ? std::string(std::strerror(errno)) : std::string(mosquitto_strerror(rc))) +
                     "; retrying with back-off, failures counted");
    }
    log::debug("broker " + endpoint(b) + ": attempt " + std::to_string(failed) + " failed");
    return false;
}

void BrokerLink::wait_for(Backoff::Duration delay) {
    std::unique_lock lock(mutex_);
    wake_.wait_for(lock, delay, [this] { return stopping_.load(); });
}

void BrokerLink::run() {
    std::minstd_rand random(std::random_device{}());
    std::uniform_real_distribution<double> spread(0.0, 1.0);
    bool first = true;
    while (!stopping_.load()) {
        if (!socket_open_.load()) {
            const bool ok = attempt(first);
            first = false;
            if (!ok) {
                Backoff::Duration delay{};
                {
                    std::lock_guard lock(mutex_);
                    delay = backoff_.next(spread(random));
                }
                wait_for(delay);
                continue;
            }
        }
        const int rc = mosquitto_loop(mosq_, kLoopTimeoutMs, 1);
        if (rc != MOSQ_ERR_SUCCESS) {
            connected_ = false;
            socket_open_ = false;
            Backoff::Duration delay{};
            {
                std::lock_guard lock(mutex_);
                delay = backoff_.next(spread(random));
            }
            wait_for(delay);
        }
    }
    say_goodbye();
}

void BrokerLink::say_goodbye() {
    if (!connected_.load()) {
        return;
    }
    int mid = 0;
    const auto status = topics_.node_status();
    if (mosquitto_publish(mosq_, &mid, status.c_str(), static_cast<int>(kOffline.size()), kOffline.data(), 1, true) ==
        MOSQ_ERR_SUCCESS) {
        goodbye_mid_ = mid;
        const auto deadline = std::chrono::steady_clock::now() + 2s;
        while (!goodbye_acked_.load() && std::chrono::steady_clock::now() < deadline) {
            if (mosquitto_loop(mosq_, kLoopTimeoutMs, 1) != MOSQ_ERR_SUCCESS) {
                break;
            }
        }
    }
    mosquitto_disconnect(mosq_);
    for (int i = 0; i < 10 && mosquitto_loop(mosq_, 10, 1) == MOSQ_ERR_SUCCESS; ++i) {
    }
    connected_ = false;
}

}  // namespace drivebus::mqtt
