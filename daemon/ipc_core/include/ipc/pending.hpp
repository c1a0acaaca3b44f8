// SPDX-License-Identifier: Apache-2.0
// The requests the ipc side has handed to the bus and not yet answered, and the one queue
// limit: a client request is booked only while fewer than `limit` are in flight, so the bus's
// rings and queues, sized to the same limit, can never refuse one for room. Every booked
// entry leaves by finish(), when the bus hands back its result or its refusal: each request
// gets exactly one answer, and the book returns to empty. Pure; `Route` is whatever the
// caller needs to answer (an iceoryx request header), opaque here.
//
// Within the limit, no flood can lock control out: a quarter of it (the control room) is kept
// for writes to a drive's command or reference under its lease (Room::Control), which every
// other request (reads, other writes) cannot take; and one client port holds at most a share
// of what is left (a quarter of it, at least 4 or all of it), so readers cannot take it all
// between two of them either. The share is the port's (Origin::port, the queue its answers go
// to), not the id a client writes in its requests: a client that changes that id with each
// request still has one share.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "drivebus/shm.hpp"
#include "ipc/admission.hpp"

namespace drivebus::ipc {

// Which room a request may use: Control, the whole limit; Shared, what the control room leaves.
enum class Room : std::uint8_t { Shared, Control };

// Who asked, and what the answer must carry.
struct Origin {
    std::uint64_t correlation = 0;  // the client's
    std::uint64_t client = 0;
    std::string client_name;
    shm::RequestKind kind = shm::RequestKind::Read;
    std::size_t drive = kBroadcast;
    std::uint32_t lease_ms = 0;
    bool fallback = false;      // drivebusd's own lease fallback, not a client's
    shm::LeaseToken token{};    // the lease token the request presents
    std::int32_t pid = 0;       // the client's, as it says
    shm::LeaseToken granted{};  // the request took a lease: its token, for this answer alone
    bool grant = false;         // it took or renewed a lease that stands only once it is sent
    Room room = Room::Shared;   // the book's: which room it was booked in
    // The port the request came through and its answer goes back to (iceoryx: the client's
    // response queue). A client that names another there never gets its answers.
    std::uint64_t port = 0;
};

template <typename Route>
class PendingBook {
public:
    struct Entry {
        Origin origin;
        std::optional<Route> route;       // empty for drivebusd's own requests
        std::optional<Route> withdrawal;  // the client's Withdraw of it, waiting for the bus's word
        bool withdrawal_asked = false;    // one per request: the rings hold one withdrawal each
    };

    explicit PendingBook(std::size_t limit)
        : limit_(limit),
          shared_room_(limit - limit / 4),
          share_(std::max(shared_room_ / 4, std::min<std::size_t>(shared_room_, 4))) {}

    // A client request: its id for the bus, or nullopt when there is no room for it (answer
    // QueueFull): `limit` in flight, the shared room full (Room::Shared), or its port's share
    // taken.
    std::optional<std::uint64_t> book(Origin origin, Route route, Room room = Room::Shared) {
        auto& mine = per_port_[origin.port];
        if (clients_ >= limit_ || (room == Room::Shared && shared_ >= shared_room_) || mine >= share_) {
            if (mine == 0) {
                per_port_.erase(origin.port);
            }
            return std::nullopt;
        }
        ++clients_;
        ++mine;
        origin.room = room;
        shared_ += room == Room::Shared ? 1 : 0;
        return add(Entry{std::move(origin), std::move(route), std::nullopt, false});
    }
    // drivebusd's own (a lease fallback): outside the clients' limit; the bus sizes its rings
    // for one per drive.
    std::uint64_t book_own(Origin origin) {
        origin.fallback = true;
        return add(Entry{std::move(origin), std::nullopt, std::nullopt, false});
    }
    // The bus answered `id`: the entry leaves the book. Nullopt for an id not booked.
    std::optional<Entry> finish(std::uint64_t id) {
        auto it = entries_.find(id);
        if (it == entries_.end()) {
            return std::nullopt;
        }
        Entry e = std::move(it->second);
        entries_.erase(it);
        if (!e.origin.fallback) {
            --clients_;
            shared_ -= e.origin.room == Room::Shared ? 1 : 0;
            if (const auto c = per_port_.find(e.origin.port); c != per_port_.end() && --c->second == 0) {
                per_port_.erase(c);
            }
        }
        return e;
    }

    // The entry of a client's request, by its port, the client's own id and correlation: only
    // the port that sent a request finds it.
    [[nodiscard]] std::optional<std::uint64_t> find(std::uint64_t port, std::uint64_t client,
                                                    std::uint64_t correlation) const {
        for (const auto& [id, e] : entries_) {
            if (!e.origin.fallback && e.origin.port == port && e.origin.client == client &&
                e.origin.correlation == correlation) {
                return id;
            }
        }
        return std::nullopt;
    }
    [[nodiscard]] Entry* entry(std::uint64_t id) {
        const auto it = entries_.find(id);
        return it == entries_.end() ? nullptr : &it->second;
    }

    [[nodiscard]] std::size_t size() const noexcept { return entries_.size(); }
    // Every id booked, in no particular order.
    [[nodiscard]] std::vector<std::uint64_t> ids() const {
        std::vector<std::uint64_t> out;
        out.reserve(entries_.size());
        for (const auto& [id, entry] : entries_) {
            out.push_back(id);
        }
        return out;
    }
    [[nodiscard]] std::size_t clients_in_flight() const noexcept { return clients_; }
    [[nodiscard]] std::size_t limit() const noexcept { return limit_; }
    // What Room::Shared requests may fill, and what one port may hold.
    [[nodiscard]] std::size_t shared_room() const noexcept { return shared_room_; }
    [[nodiscard]] std::size_t share() const noexcept { return share_; }

private:
    std::uint64_t add(Entry e) {
        const std::uint64_t id = next_id_++;
        entries_.emplace(id, std::move(e));
        return id;
    }

    std::size_t limit_;
    std::size_t shared_room_;
    std::size_t share_;
    std::size_t clients_ = 0;
    std::size_t shared_ = 0;                                   // client requests in the shared room
    std::unordered_map<std::uint64_t, std::size_t> per_port_;  // in flight, by port
    std::uint64_t next_id_ = 1;
    std::unordered_map<std::uint64_t, Entry> entries_;
};

}  // namespace drivebus::ipc
