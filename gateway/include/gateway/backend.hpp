// SPDX-License-Identifier: Apache-2.0
// What the gateway's server needs of drivebusd, behind one small interface: the real one is
// libdrivebus (drivebus_backend.cpp), a test gives a fake.
#pragma once

#include <cstdint>
#include <expected>
#include <optional>
#include <string>

#include "drivebus/client.hpp"
#include "drivebus/shm.hpp"

namespace drivebus::gateway {

// The drive a unit id reaches.
struct Route {
    std::string bus;
    std::string drive;  // its name on that bus
};

class Backend {
public:
    Backend() = default;
    virtual ~Backend() = default;
    Backend(const Backend&) = delete;
    Backend& operator=(const Backend&) = delete;
    Backend(Backend&&) = delete;
    Backend& operator=(Backend&&) = delete;

    // Nothing when no drive answers to `unit`.
    [[nodiscard]] virtual const Route* route(std::uint8_t unit) const = 0;
    // The drive's latest snapshot (nothing before the first).
    [[nodiscard]] virtual std::optional<shm::DriveSnapshot> snapshot(std::uint8_t unit) const = 0;
    // Sends `request` to the drive's bus and waits for its answer. Called on a worker thread,
    // several at once.
    [[nodiscard]] virtual std::expected<shm::Response, Error> request(std::uint8_t unit,
                                                                      const shm::Request& request) = 0;
};

}  // namespace drivebus::gateway
