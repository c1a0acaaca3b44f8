// SPDX-License-Identifier: Apache-2.0
// The bus thread's side of the hand-over: it takes client requests off the ring and gives
// each to the engine or answers it at once (BusDown, QueueFull, UnknownDrive), hands every
// result and snapshot back, and keeps the lease fallbacks: each in its drive's own slot,
// retried until the drive acknowledges it or is absent. Bus thread only; no lock, and no
// allocation after construction.
#pragma once

#include <optional>
#include <vector>

#include "bus/handover.hpp"
#include "config/config.hpp"
#include "master/bus_engine.hpp"

namespace drivebus::bus {

class Desk {
public:
    Desk(const config::BusConfig& bus, Handover& handover);
    Desk(const Desk&) = delete;
    Desk& operator=(const Desk&) = delete;
    Desk(Desk&&) = delete;
    Desk& operator=(Desk&&) = delete;

    // The engine's callbacks: results and snapshots to the hand-over, and to `user`'s if set.
    [[nodiscard]] master::EngineCallbacks callbacks(const master::EngineCallbacks& user);
    // The engine those callbacks were given to (before the bus thread runs).
    void attach(master::BusEngine& engine) noexcept { engine_ = &engine; }

    // Every request waiting in the ring: the engine's now, or answered now.
    void take_requests();
    // Fallbacks due for another try.
    void retry_fallbacks(rtu::Instant now);
    [[nodiscard]] std::optional<rtu::Instant> next_retry() const;

private:
    void take_fallback(const master::ClientRequest& request);
    bool fallback_finished(std::uint64_t id, const master::Result& r);

    struct Fallback {
        std::optional<master::ClientRequest> request;  // waiting, on the wire, or to be retried
        bool retry = false;
        rtu::Instant retry_at{};
    };

    const config::BusConfig& bus_;
    Handover& handover_;
    master::BusEngine* engine_ = nullptr;
    std::vector<Fallback> fallbacks_;  // one slot per drive
};

}  // namespace drivebus::bus
