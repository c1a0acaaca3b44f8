// SPDX-License-Identifier: Apache-2.0
// The gateway's Modbus side, pure: every connection's requests in the order they came, what is
// answered from the snapshot, what goes to drivebusd and when, the write memo and the lease
// tokens. No socket, no clock, no thread, no log: events in (bytes a connection sent, what is
// still unsent to it, drivebusd's answers, the time), effects out (bytes to send, requests for
// drivebusd, connections to close, lines to log). The server (server.cpp) carries them out on
// its loop; tests drive it on a virtual clock (tests/gateway/session_test.cpp).
//
// The rules (docs/gateway.md):
// - a connection's answers go in the order of its requests; its head waits while it is with
//   drivebusd, so it has at most one request there;
// - at most `workers` requests are with drivebusd at once; the others wait their turn in the
//   order they came;
// - a connection reads ahead at most `max_pipelined` requests, and none is taken while more than
//   `max_unsent` bytes of its answers wait to go (its client is not reading them);
// - the lease a write took is the connection's own: later requests to that bus present its
//   token; where it holds none it presents a random one no lease has;
// - a register is never answered from a snapshot older than what the gateway last gave of it: a
//   write it carried (acknowledged), or a value read from the drive through drivebusd (route.hpp),
//   so that no client reads a value go back in time; a memo older than max_age is forgotten;
// - a connection with no request for idle_timeout, and nothing with drivebusd, is closed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "gateway/backend.hpp"
#include "gateway/mbap.hpp"
#include "gateway/pdu.hpp"
#include "gateway/stats.hpp"

namespace drivebus::gateway {

struct SessionLimits {
    std::size_t max_pipelined = 16;
    std::size_t workers = 4;
    std::int64_t max_age_ns = 0;
    std::int64_t idle_timeout_ns = 0;  // 0: connections are never closed for idling
    std::size_t max_unsent = std::size_t{64} * 1024;
};

// A request for drivebusd; its answer comes back through Session::answered with its ticket.
struct Outgoing {
    std::uint64_t ticket = 0;
    std::uint8_t unit = 0;
    shm::Request request;  // lease token and client name filled
};

enum class Severity : std::uint8_t { Info, Notice, Warning };

struct Note {
    Severity severity = Severity::Info;
    std::string text;
    std::string bus;  // empty when it concerns no drive
    std::string drive;
};

struct Effects {
    std::vector<std::pair<std::uint64_t, std::vector<std::uint8_t>>> replies;  // connection, ADU
    std::vector<Outgoing> requests;
    std::vector<std::pair<std::uint64_t, std::string>> closes;  // connection, why
    std::vector<Note> notes;
};

class Session {
public:
    Session(SessionLimits limits, const Directory& directory);

    // A connection accepted: its peer ("10.0.0.5:50122"; drivebusd shows the client as
    // "tcp 10.0.0.5:50122"), its right to write, and the token it presents where it holds no lease (random, never
    // zero).
    void open(std::uint64_t id, std::string peer, bool may_write, shm::LeaseToken none, std::int64_t now_ns);
    // The connection is gone (closed by its client, reset, or by an effect): its waiting
    // requests are dropped; an answer still to come for it is taken and dropped.
    void close(std::uint64_t id);

    // Bytes the connection sent.
    Effects received(std::uint64_t id, std::span<const std::uint8_t> bytes, std::int64_t now_ns);
    // How many of its answers' bytes are still unsent (after the server wrote what it could).
    Effects unsent(std::uint64_t id, std::size_t bytes, std::int64_t now_ns);
    // drivebusd's answer to the request with this ticket (or the library's error).
    Effects answered(std::uint64_t ticket, const std::expected<shm::Response, Error>& result, std::int64_t now_ns);
    // Once in a while (the server: every second): idle connections, the write memo.
    Effects tick(std::int64_t now_ns);

    // Whether the server should read from the connection: below both read-ahead bounds.
    [[nodiscard]] bool reading(std::uint64_t id) const;
    [[nodiscard]] std::size_t connections() const noexcept { return connections_.size(); }
    // The counters it keeps (requests, from_snapshot, sent, exceptions, refused_writes,
    // idle_closed, broken_streams, waiting); the server adds its own.
    [[nodiscard]] const Stats& stats() const noexcept { return stats_; }

private:
    struct Connection {
        std::string peer;
        bool may_write = false;
        shm::LeaseToken none{};
        MbapReader reader;
        std::deque<Adu> queue;  // taken, not answered; the head is with drivebusd while `busy`
        bool busy = false;
        std::size_t unsent = 0;
        std::int64_t last_request_ns = 0;
        std::map<std::string, shm::LeaseToken, std::less<>> tokens;  // by bus
    };
    struct Job {
        std::uint64_t connection = 0;
        std::uint16_t transaction = 0;
        std::uint8_t unit = 0;
        Call call;
        shm::Request request;
    };

    void pump(std::uint64_t id, std::int64_t now_ns, Effects& out);
    // Answers the request at once or hands it on to drivebusd.
    void take(std::uint64_t id, Connection& c, const Adu& adu, std::int64_t now_ns, Effects& out);
    void reply(std::uint64_t id, Connection& c, std::uint16_t transaction, std::uint8_t unit,
               const std::vector<std::uint8_t>& pdu, Effects& out);
    void send(Job job, Effects& out);
    void refused_write(const Connection& c, std::uint8_t unit, const WriteRegisters& write, const std::string& why,
                       Effects& out);
    void drop(std::uint64_t id, std::string why, Effects& out);

    SessionLimits limits_;
    const Directory& directory_;
    std::map<std::uint64_t, Connection> connections_;
    std::map<std::uint64_t, Job> with_drivebusd_;  // by ticket
    std::deque<Job> turns_;                        // waiting for one of those to be answered
    std::uint64_t next_ticket_ = 1;
    // By drive (bus, name: two unit ids may reach one drive) and register: when the value the
    // gateway last gave of it was current (a write acknowledged, a reply read through drivebusd).
    std::map<std::pair<std::string, std::string>, std::map<std::uint16_t, std::int64_t>> given_;
    Stats stats_;
};

}  // namespace drivebus::gateway
