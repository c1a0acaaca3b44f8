// SPDX-License-Identifier: Apache-2.0
// The Modbus TCP server: one event loop thread owns the sockets (accept, read, answer) and
// drivebusd's descriptors: the requests that need drivebusd go out without waiting, and their
// answers come back in the same loop (Backend::dispatch; libdrivebus on Delivery::Dispatch), so
// the gateway has no other thread. What to answer, in which order, and when a request goes to
// drivebusd is the pure Session's (session.hpp); the server carries its effects out: it writes
// the answers, sends the requests, closes, logs, and reads from a connection only while the
// session takes more of it (past max_pipelined requests read ahead or 64 KiB of unsent answers
// it stops: TCP makes the client wait). It owns the bounds on connections themselves:
// max_connections and allow_from (others are closed at once), write_from, TCP keepalive.
//
// A write's control lease belongs to the connection that made it: a later write of another
// connection is refused (0x06) while it holds. Closing the connection does not release it: the
// lease runs out and drivebusd applies the drive's fallback, as for any client that goes.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "gateway/backend.hpp"
#include "gateway/config.hpp"
#include "gateway/session.hpp"
#include "gateway/stats.hpp"
#include "sys/event_fd.hpp"
#include "sys/event_loop.hpp"

namespace drivebus::gateway {

class Server {
public:
    // Binds and listens (throws std::system_error naming the address).
    Server(Config config, Backend& backend);
    ~Server();
    Server(const Server&) = delete;
    Server& operator=(const Server&) = delete;
    Server(Server&&) = delete;
    Server& operator=(Server&&) = delete;

    // The port it listens on (the one chosen when listen's port is 0).
    [[nodiscard]] std::uint16_t port() const noexcept { return port_; }
    // The loop the server runs in: main adds its signalfd to it.
    [[nodiscard]] sys::EventLoop& loop() noexcept { return loop_; }
    // Runs until stop(); an epoll failure is thrown as std::system_error.
    void run();
    // From any thread.
    void stop() noexcept;
    [[nodiscard]] Stats stats() const;

private:
    struct Connection;

    void accept_all();
    void on_ready(std::uint64_t id, sys::Readiness readiness);
    void read_from(Connection& c);
    // Carries out the session's effects, and those they lead to (a connection's answers
    // written, what waited behind them taken).
    void carry(Effects effects);
    void flush(Connection& c);
    void update_interest(Connection& c);
    // The session knows already (or told us): the socket goes.
    void close_socket(std::uint64_t id, const std::string& why);
    void close(std::uint64_t id, const std::string& why);
    void on_tick();
    void publish();

    Config config_;
    Backend& backend_;
    Session session_;
    sys::EventLoop loop_;
    sys::UniqueFd listener_;
    std::uint16_t port_ = 0;
    sys::EventFd stop_{"eventfd to stop the gateway"};
    sys::Timer tick_;
    std::map<std::uint64_t, std::unique_ptr<Connection>> connections_;
    std::uint64_t next_id_ = 1;
    Stats own_;                 // connections, refused_connections
    mutable std::mutex mutex_;  // stats_: stats() is asked from other threads
    Stats stats_;
};

}  // namespace drivebus::gateway
