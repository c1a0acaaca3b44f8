// SPDX-License-Identifier: Apache-2.0
// The Modbus TCP server: one event loop thread owns the sockets (accept, read, answer) and
// drivebusd's descriptors: the requests that need drivebusd go out without waiting, and their
// answers come back in the same loop (Backend::dispatch; libdrivebus on Delivery::Dispatch), so
// the gateway has no other thread. Each connection's requests are answered in the order they
// came (its head waits while it is with drivebusd), a connection has at most one request with
// drivebusd at a time, and at most `workers` are under way at once (the others wait their
// turn, in the order they came), so connections take turns: one that floods waits behind its
// own requests, not others'.
//
// Bounds: max_connections (more are closed at once), max_pipelined requests read ahead per
// connection and 64 KiB of unsent answers (past either the gateway stops reading from that
// connection: TCP makes its client wait), idle_timeout. A write's control lease belongs to the
// connection that made it: a later write of another connection is refused (0x06) while it
// holds. Closing the connection does not release it: the lease runs out and drivebusd applies
// the drive's fallback, as for any client that goes.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "gateway/backend.hpp"
#include "gateway/config.hpp"
#include "gateway/mbap.hpp"
#include "gateway/pdu.hpp"
#include "sys/event_fd.hpp"
#include "sys/event_loop.hpp"

namespace drivebus::gateway {

struct Stats {
    std::uint64_t connections = 0;          // accepted
    std::uint64_t refused_connections = 0;  // over max_connections or not in allow_from
    std::uint64_t requests = 0;             // ADUs taken
    std::uint64_t from_snapshot = 0;        // answered from a snapshot
    std::uint64_t sent = 0;                 // sent to drivebusd
    std::uint64_t exceptions = 0;           // answered with an exception
    std::uint64_t refused_writes = 0;
    std::uint64_t idle_closed = 0;
    std::uint64_t broken_streams = 0;  // closed: not Modbus TCP
    std::uint64_t open = 0;            // connections open now
    std::uint64_t waiting = 0;         // requests waiting their turn now (`workers` under way)
};

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
    struct Job {
        std::uint64_t connection = 0;
        std::uint16_t transaction = 0;
        std::uint8_t unit = 0;
        Call call;
        shm::Request request;
    };
    struct Done {
        Job job;
        std::expected<shm::Response, Error> result;
    };

    void accept_all();
    void on_ready(std::uint64_t id, sys::Readiness readiness);
    void read_from(Connection& c);
    // Answers what it can of the connection's queue, in order, until its head goes to drivebusd.
    void pump(Connection& c);
    void take(Connection& c, const Adu& adu);
    void reply(Connection& c, std::uint16_t transaction, std::uint8_t unit, const std::vector<std::uint8_t>& pdu);
    void flush(Connection& c);
    void update_interest(Connection& c);
    void close(std::uint64_t id, const char* why);
    // A request to drivebusd, and its answer.
    void send(Job job);
    void on_done(Done d);
    void on_tick();
    void bump(std::uint64_t Stats::* field);
    void set_open();
    void set_waiting();
    void log_refused_write(const Connection& c, std::uint8_t unit, const WriteRegisters& write, const std::string& why);

    Config config_;
    Backend& backend_;
    sys::EventLoop loop_;
    sys::UniqueFd listener_;
    std::uint16_t port_ = 0;
    sys::EventFd stop_{"eventfd to stop the gateway"};
    sys::Timer tick_;
    std::map<std::uint64_t, std::unique_ptr<Connection>> connections_;
    // By drive (bus, name: two unit ids may reach one drive) and register: when a write through
    // the gateway was acknowledged (route.hpp).
    std::map<std::pair<std::string, std::string>, std::map<std::uint16_t, std::int64_t>> written_;
    std::uint64_t next_id_ = 1;

    std::size_t in_flight_ = 0;  // with drivebusd
    std::deque<Job> turns_;      // waiting for one of those to be answered
    mutable std::mutex mutex_;   // stats_: stats() is asked from other threads
    Stats stats_;
};

}  // namespace drivebus::gateway
