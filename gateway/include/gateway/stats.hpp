// SPDX-License-Identifier: Apache-2.0
// The gateway's counters, as its status and its log show them: the server keeps the
// connections', the session (session.hpp) the requests'.
#pragma once

#include <cstdint>

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

}  // namespace drivebus::gateway
