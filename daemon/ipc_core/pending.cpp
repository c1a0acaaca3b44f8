// SPDX-License-Identifier: Apache-2.0
#include "ipc/pending.hpp"

#include <algorithm>

namespace drivebus::ipc {

PendingBook::PendingBook(std::size_t limit)
    : limit_(limit),
      shared_room_(limit - limit / 4),
      share_(std::max(shared_room_ / 4, std::min<std::size_t>(shared_room_, 4))) {}

std::optional<std::uint64_t> PendingBook::book(Origin origin, RouteId route, Room room) {
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
    return add(Entry{std::move(origin), route, std::nullopt, false});
}

std::uint64_t PendingBook::book_own(Origin origin) {
    origin.fallback = true;
    return add(Entry{std::move(origin), std::nullopt, std::nullopt, false});
}

std::optional<PendingBook::Entry> PendingBook::finish(std::uint64_t id) {
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

std::optional<std::uint64_t> PendingBook::find(std::uint64_t port, std::uint64_t client,
                                               std::uint64_t correlation) const {
    for (const auto& [id, e] : entries_) {
        if (!e.origin.fallback && e.origin.port == port && e.origin.client == client &&
            e.origin.correlation == correlation) {
            return id;
        }
    }
    return std::nullopt;
}

PendingBook::Entry* PendingBook::entry(std::uint64_t id) {
    const auto it = entries_.find(id);
    return it == entries_.end() ? nullptr : &it->second;
}

std::vector<std::uint64_t> PendingBook::ids() const {
    std::vector<std::uint64_t> out;
    out.reserve(entries_.size());
    for (const auto& [id, entry] : entries_) {
        out.push_back(id);
    }
    return out;
}

std::uint64_t PendingBook::add(Entry e) {
    const std::uint64_t id = next_id_++;
    entries_.emplace(id, std::move(e));
    return id;
}

}  // namespace drivebus::ipc
