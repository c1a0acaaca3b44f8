// SPDX-License-Identifier: Apache-2.0
// What a bus publishes in shared memory: a snapshot per drive and the bus status. The one
// owner of what subscribers see: each drive's published sequence (poll cycles and lease
// changes alike), its last snapshot, and its health as the bus last reported it. Runs on the
// ipc thread only.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "ipc/host.hpp"
#include "log/log.hpp"
#include "master/snapshot.hpp"

namespace drivebus::ipc {

class Publisher {
public:
    Publisher(const config::BusConfig& bus, const Layout& layout);
    ~Publisher();
    Publisher(const Publisher&) = delete;
    Publisher& operator=(const Publisher&) = delete;
    Publisher(Publisher&&) = delete;
    Publisher& operator=(Publisher&&) = delete;

    // The index of the drive a snapshot is about.
    [[nodiscard]] std::optional<std::size_t> drive_index(std::string_view name) const;
    // A drive's poll cycle, with the drive's lease as it stands. True when its health changed.
    bool snapshot(std::size_t drive, const master::DriveSnapshot& s, const shm::LeaseStatus& lease);
    // The drive's lease changed: its last snapshot again, with the new lease.
    void lease(std::size_t drive, const shm::LeaseStatus& lease);
    // The bus status, with what the ipc side counts.
    struct IpcCounts {
        std::uint64_t served = 0;
        std::uint64_t queue_full = 0;  // answered QueueFull at the intake's limit
        std::uint64_t lease_expiries = 0;
    };
    void status(const master::BusStatus& bus, const IpcCounts& counts);

    // Each drive's last published sequence, by name, and the same taken over (a bus restarted
    // by a reload): its subscribers wait for a sequence above the last they saw.
    [[nodiscard]] std::vector<std::pair<std::string, std::uint64_t>> sequences() const;
    void continue_sequences(const std::vector<std::pair<std::string, std::uint64_t>>& sequences);

    // Samples published so far, snapshots and statuses.
    [[nodiscard]] std::uint64_t publications() const noexcept { return publications_; }

    // Any thread (systemd's status line).
    [[nodiscard]] std::size_t drives_online() const noexcept { return online_.load(std::memory_order_relaxed); }

    struct Channels;

private:
    void publish(std::size_t drive);
    void log_health(std::size_t drive, master::Health before, master::Health now, const master::SetupNote& note);
    void log_comm_timeout(std::size_t drive, const master::CommTimeoutNote& note);

    const config::BusConfig& bus_;
    std::string control_group_;
    std::unique_ptr<Channels> channels_;
    std::vector<shm::DriveSnapshot> last_;
    std::vector<master::Health> health_;
    std::vector<bool> comm_timeout_logged_;  // per drive: its time-out was logged
    std::atomic<std::size_t> online_{0};
    std::uint64_t publications_ = 0;
    log::RateLimited absent_log_;
};

}  // namespace drivebus::ipc
