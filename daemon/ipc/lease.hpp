// Control leases: the client that writes a drive's command or reference holds the drive's lease
// and must renew it; another client is refused (unless it takes the lease over); a lease that
// runs out gets the drive's fallback. Pure: time is an argument.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "rtu/timing.hpp"

namespace drivebus::ipc {

struct LeaseDecision {
    bool allowed = false;
    bool taken_over = false;     // the lease moved from another client
    bool changed = false;        // taken (not merely renewed): holder or state differ
    std::uint64_t holder = 0;    // the holder after the decision (the refuser's holder when denied)
    std::string holder_name;     // for messages
    std::uint32_t lease_ms = 0;  // granted length when allowed
};

struct Expiry {
    std::size_t drive = 0;
    std::uint64_t holder = 0;
    std::string holder_name;
    config::LeaseFallback fallback = config::LeaseFallback::Hold;
};

class LeaseTable {
public:
    explicit LeaseTable(const config::BusConfig& bus);

    // A write to the drive's command or reference by `client`: takes or renews the lease, or
    // refuses when another client holds it and `take_over` is false.
    LeaseDecision acquire(std::size_t drive, std::uint64_t client, std::string_view name, bool take_over,
                          rtu::Instant now);
    // Renews the lease `client` holds; refuses when it holds none on that drive.
    LeaseDecision renew(std::size_t drive, std::uint64_t client, rtu::Instant now);
    // Gives the lease up (no fallback). False when `client` did not hold it.
    bool release(std::size_t drive, std::uint64_t client);
    // Whether someone other than `client` holds a live lease on any drive (for broadcasts).
    [[nodiscard]] std::optional<std::uint64_t> other_holder(std::uint64_t client) const;

    // Leases that have run out by `now`; each becomes Expired and is returned once.
    std::vector<Expiry> expire(rtu::Instant now);
    // The next expiry, if any lease is held.
    [[nodiscard]] std::optional<rtu::Instant> next_deadline() const;
    // The fallback's write was answered (or not).
    void fallback_result(std::size_t drive, bool ok);

    [[nodiscard]] shm::LeaseStatus status(std::size_t drive) const;
    [[nodiscard]] std::uint64_t expiries() const noexcept { return expiries_; }

private:
    struct Lease {
        std::uint64_t holder = 0;
        std::string holder_name;
        rtu::Instant expires{};
        shm::LeaseState state = shm::LeaseState::Free;
        rtu::Duration duration{};
        config::LeaseFallback fallback = config::LeaseFallback::Hold;
        bool fallback_ok = false;
        rtu::Instant expired{};
        std::uint64_t expiries = 0;
    };
    std::vector<Lease> leases_;
    std::uint64_t expiries_ = 0;
};

}  // namespace drivebus::ipc
