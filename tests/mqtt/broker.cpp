// SPDX-License-Identifier: Apache-2.0
#include "broker.hpp"

#include <arpa/inet.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <stdexcept>

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

sockaddr_in loopback(int port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    return a;
}

int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    auto a = loopback(0);
    socklen_t size = sizeof(a);
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &size) != 0) {
        throw std::runtime_error("no free loopback port");
    }
    ::close(fd);
    return ntohs(a.sin_port);
}

bool accepts(int port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const auto a = loopback(port);
    const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) == 0;
    ::close(fd);
    return ok;
}

}  // namespace

Broker::Broker(int port, const std::string& extra) : port_(port == 0 ? free_port() : port) {
    if (std::string(MOSQUITTO_PATH).empty() || !fs::exists(MOSQUITTO_PATH)) {
        throw std::runtime_error("no mosquitto broker (Debian package mosquitto): scripts/setup installs it");
    }
    dir_ =
        fs::temp_directory_path() / ("drivebus-mosquitto-" + std::to_string(::getpid()) + "-" + std::to_string(port_));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "mosquitto.conf")
        << "listener " << port_ << " 127.0.0.1\n"
        << (extra.find("allow_anonymous") == std::string::npos ? "allow_anonymous true\n" : "")
        << "persistence false\nset_tcp_nodelay true\nlog_dest stderr\nlog_type error\nlog_type warning\n"
        << "log_type notice\nlog_type information\n"
        << extra;
    start();
}

Broker::~Broker() {
    process_.reset();
    std::error_code ec;
    fs::remove_all(dir_, ec);
}

void Broker::stop() {
    if (process_) {
        process_->stop();
        process_.reset();
    }
}

void Broker::start() {
    process_ =
        std::make_unique<Child>(std::vector<std::string>{MOSQUITTO_PATH, "-c", (dir_ / "mosquitto.conf").string()});
    if (!wait_until([&] { return accepts(port_); }, 10s)) {
        throw std::runtime_error("mosquitto did not start on port " + std::to_string(port_) + ": " +
                                 process_->output());
    }
}

Watcher::Watcher(int port, const std::string& filter) : filter_(filter) {
    mosquitto_lib_init();
    mosq_ = mosquitto_new(nullptr, true, this);
    if (mosq_ == nullptr) {
        throw std::runtime_error("mosquitto_new failed");
    }
    mosquitto_connect_callback_set(mosq_, &Watcher::on_connect);
    mosquitto_message_callback_set(mosq_, &Watcher::on_message);
    mosquitto_reconnect_delay_set(mosq_, 1, 1, false);
    mosquitto_connect_async(mosq_, "127.0.0.1", port, 5);
    if (mosquitto_loop_start(mosq_) != MOSQ_ERR_SUCCESS) {
        throw std::runtime_error("mosquitto_loop_start failed");
    }
}

Watcher::~Watcher() {
    mosquitto_disconnect(mosq_);
    mosquitto_loop_stop(mosq_, true);
    mosquitto_destroy(mosq_);
    mosquitto_lib_cleanup();
}

void Watcher::on_connect(mosquitto* m, void* self, int rc) {
    if (rc == 0) {
        mosquitto_subscribe(m, nullptr, static_cast<Watcher*>(self)->filter_.c_str(), 1);
    }
}

void Watcher::on_message(mosquitto* /*m*/, void* self, const mosquitto_message* message) {
    auto& w = *static_cast<Watcher*>(self);
    {
        std::lock_guard lock(w.mutex_);
        w.messages_.push_back(Message{
            message->topic,
            std::string(static_cast<const char*>(message->payload), static_cast<std::size_t>(message->payloadlen)),
            message->retain});
    }
    w.arrived_.notify_all();
}

std::optional<Message> Watcher::wait(const std::string& topic, const std::function<bool(const Message&)>& accept,
                                     std::chrono::milliseconds timeout, std::size_t from) {
    std::unique_lock lock(mutex_);
    std::optional<Message> found;
    arrived_.wait_for(lock, timeout, [&] {
        for (std::size_t i = from; i < messages_.size(); ++i) {
            if (messages_[i].topic == topic && accept(messages_[i])) {
                found = messages_[i];
                return true;
            }
        }
        from = messages_.size();
        return false;
    });
    return found;
}

std::size_t Watcher::count() const {
    std::lock_guard lock(mutex_);
    return messages_.size();
}

std::vector<Message> Watcher::messages() const {
    std::lock_guard lock(mutex_);
    return messages_;
}

bool Watcher::publish(const std::string& topic, const std::string& payload, int qos) {
    return mosquitto_publish(mosq_, nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), qos,
                             false) == MOSQ_ERR_SUCCESS;
}

std::pair<int, std::string> mosquitto_pub(int port, const std::string& topic, const std::string& payload, bool retain) {
    std::vector<std::string> argv{
        MOSQUITTO_PUB_PATH, "-h", "127.0.0.1", "-p", std::to_string(port), "-q", "1", "-t", topic, "-m", payload};
    if (retain) {
        argv.emplace_back("-r");
    }
    return run_program(argv);
}

std::pair<int, std::string> mosquitto_sub_one(int port, const std::string& topic) {
    return run_program({MOSQUITTO_SUB_PATH, "-h", "127.0.0.1", "-p", std::to_string(port), "-t", topic, "-C", "1", "-W",
                        "5", "--retained-only"});
}

}  // namespace drivebus::test
