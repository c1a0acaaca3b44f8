// SPDX-License-Identifier: Apache-2.0
// The requests the ipc side has handed to the bus and not yet answered, and the one queue
// limit: a client request is booked only while fewer than `limit` are in flight, so the bus's
// rings and queues, sized to the same limit, can never refuse one for room. Every booked
// entry leaves by finish(), when the bus hands back its result or its refusal: each request
// gets exactly one answer, and the book returns to empty. Pure; a request's route (RouteId) is
// the caller's, opaque here.
//
// Within the limit, no flood can lock control out: a quarter of it (the control room) is kept
// for writes to a drive's command or reference under its lease (Room::Control), which every
// other request (reads, other writes) cannot take; and one client port holds at most a share
// of what is left (a quarter of it, at least 4 or all of it), so readers cannot take it all
// between two of them either. The share is the port's (Origin::port, the queue its answers go
// to), not the id a client writes in its requests: a client that changes that id with each
// request still has one share.
#pragma once

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

// What a caller answers a request through, chosen by the caller (drivebusd: a key to the
// iceoryx request headers it keeps): opaque here, handed back with the request's answer.
using RouteId = std::uint64_t;

class PendingBook {
public:
    struct Entry {
        Origin origin;
        std::optional<RouteId> route;       // empty for drivebusd's own requests
        std::optional<RouteId> withdrawal;  // the client's Withdraw of it, waiting for the bus's word
        bool withdrawal_asked = false;      // one per request: the rings hold one withdrawal each
    };

    explicit PendingBook(std::size_t limit);

    // A client request: its id for the bus, or nullopt when there is no room for it (answer
    // QueueFull): `limit` in flight, the shared room full (Room::Shared), or its port's share
    // taken.
    std::optional<std::uint64_t> book(Origin origin, RouteId route, Room room = Room::Shared);
    // drivebusd's own (a lease fallback): outside the clients' limit; the bus sizes its rings
    // for one per drive.
    std::uint64_t book_own(Origin origin);
    // The bus answered `id`: the entry leaves the book. Nullopt for an id not booked.
    std::optional<Entry> finish(std::uint64_t id);

    // The entry of a client's request, by its port, the client's own id and correlation: only
    // the port that sent a request finds it.
    [[nodiscard]] std::optional<std::uint64_t> find(std::uint64_t port, std::uint64_t client,
                                                    std::uint64_t correlation) const;
    [[nodiscard]] Entry* entry(std::uint64_t id);

    [[nodiscard]] std::size_t size() const noexcept { return entries_.size(); }
    // Every id booked, in no particular order.
    [[nodiscard]] std::vector<std::uint64_t> ids() const;
    [[nodiscard]] std::size_t clients_in_flight() const noexcept { return clients_; }
    [[nodiscard]] std::size_t limit() const noexcept { return limit_; }
    // What Room::Shared requests may fill, and what one port may hold.
    [[nodiscard]] std::size_t shared_room() const noexcept { return shared_room_; }
    [[nodiscard]] std::size_t share() const noexcept { return share_; }

private:
    std::uint64_t add(Entry e);

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
