// SPDX-License-Identifier: Apache-2.0
// The gateway's Backend on libdrivebus: one Bus per bus the units reach, each on the server's
// event loop (Delivery::Dispatch), the unit ids resolved to drives once at start.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "drivebus/client.hpp"
#include "gateway/backend.hpp"
#include "gateway/config.hpp"

namespace drivebus::gateway {

class DrivebusBackend final : public Backend {
public:
    // Connects to drivebusd and resolves every route; the error is one line (NotRunning when
    // drivebusd does not run yet: the caller may wait and try again).
    static std::expected<std::unique_ptr<DrivebusBackend>, Error> connect(const Config& config);

    [[nodiscard]] const Route* route(std::uint8_t unit) const override;
    [[nodiscard]] std::optional<shm::DriveSnapshot> snapshot(std::uint8_t unit) const override;
    void submit(std::uint8_t unit, const shm::Request& request, Done done) override;
    // Each bus's descriptor (its Bus runs on Delivery::Dispatch, with no thread of its own).
    [[nodiscard]] std::vector<int> descriptors() const override;
    void dispatch() override;
    // Whether drivebusd still publishes every bus's status.
    [[nodiscard]] bool alive() const;
    // "unit 1 line1/pump, unit 2 line1/fan".
    [[nodiscard]] std::string describe() const;

private:
    struct Unit {
        Route route;
        const Bus* bus = nullptr;
        Drive drive;
    };
    DrivebusBackend() = default;
    std::expected<Bus*, Error> bus(const std::string& name, const ConnectOptions& options);

    std::map<std::string, std::unique_ptr<Bus>> buses_;
    std::array<std::optional<Unit>, 256> units_;
};

}  // namespace drivebus::gateway
