// SPDX-License-Identifier: Apache-2.0
// What the gateway's server needs of drivebusd, behind one small interface: the real one is
// libdrivebus (drivebus_backend.cpp), a test gives a fake.
#pragma once

#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "drivebus/client.hpp"
#include "drivebus/shm.hpp"

namespace drivebus::gateway {

// The drive a unit id reaches.
struct Route {
    std::string bus;
    std::string drive;  // its name on that bus
};

// What the session (session.hpp) reads of drivebusd: which drive a unit reaches, and its latest
// snapshot.
class Directory {
public:
    Directory() = default;
    virtual ~Directory() = default;
    Directory(const Directory&) = delete;
    Directory& operator=(const Directory&) = delete;
    Directory(Directory&&) = delete;
    Directory& operator=(Directory&&) = delete;

    // Nothing when no drive answers to `unit`.
    [[nodiscard]] virtual const Route* route(std::uint8_t unit) const = 0;
    // The drive's latest snapshot (nothing before the first).
    [[nodiscard]] virtual std::optional<shm::DriveSnapshot> snapshot(std::uint8_t unit) const = 0;
};

class Backend : public Directory {
public:
    // Sends `request` to the drive's bus and returns at once; `done` runs later, in dispatch()
    // on the server's loop thread, with its answer: exactly once while the backend lives.
    using Done = std::function<void(std::expected<shm::Response, Error>)>;
    virtual void submit(std::uint8_t unit, const shm::Request& request, Done done) = 0;
    // The descriptors the server's loop watches for the backend: when one is readable, the loop
    // calls dispatch(), which runs the answers that have come (and takes new snapshots).
    [[nodiscard]] virtual std::vector<int> descriptors() const = 0;
    virtual void dispatch() = 0;
};

}  // namespace drivebus::gateway
