// SPDX-License-Identifier: Apache-2.0
// Control leases: the client that writes a drive's command or reference holds the drive's lease
// and must renew it; another client is refused (unless it takes the lease over); a lease that
// runs out gets the drive's fallback. Pure: time is an argument, and the secret tokens come
// from a source the caller gives (getrandom in drivebusd, a counter in tests).
//
// A lease is a capability, not a name: taking it hands its holder a secret token, and only a
// request that presents that token renews it, writes under it or releases it. Who holds it
// (a display name and pid, the client's own word) is published; the token never is. A client
// that takes a lease while presenting the token of a lease it holds on another drive keeps
// that token, so one client's live leases share one token (its broadcasts present it).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "rtu/timing.hpp"

namespace drivebus::ipc {

using shm::LeaseToken;
// A fresh secret, never all zero (zero presents nothing).
using TokenSource = std::function<LeaseToken()>;

// Who a lease is published as holding: what the client says it is, for people to read.
struct Holder {
    std::string name;  // "pump-control[1234]"
    std::int32_t pid = 0;
};

struct LeaseDecision {
    bool allowed = false;
    bool taken_over = false;     // the lease moved from another client
    bool changed = false;        // taken (not merely renewed): holder or state differ
    Holder holder;               // the holder after the decision (the refuser's holder when denied)
    LeaseToken token{};          // taken: the token to hand to the taker alone; zero otherwise
    std::uint32_t lease_ms = 0;  // granted length when allowed
};

// A held lease taken from one LeaseTable to another: a bus restarted by a reload keeps its
// holders, their tokens and their deadlines, drive by drive.
struct HeldLease {
    std::size_t drive = 0;
    Holder holder;
    LeaseToken token{};
    rtu::Instant expires{};
};

struct Expiry {
    std::size_t drive = 0;
    Holder holder;
    config::LeaseFallback fallback = config::LeaseFallback::Hold;
};

class LeaseTable {
public:
    LeaseTable(const config::BusConfig& bus, TokenSource tokens);

    // A write to the drive's command or reference presenting `token`: takes or renews the
    // lease, or refuses when the lease is live under another token and `take_over` is false.
    // A `grant` id other than 0: the write has not reached the wire yet, and what it took or
    // renewed stands only once settle() says it went; refused, it is undone.
    LeaseDecision acquire(std::size_t drive, const LeaseToken& token, const Holder& who, bool take_over,
                          rtu::Instant now, std::uint64_t grant = 0);
    // The write of `grant` went to the wire (`sent`: what it took stands), or was refused before
    // it did: the lease is put back exactly as it was before the grant (holder, token, expiry),
    // unless something after it has since changed the lease, which then stands. True when the
    // lease changed.
    bool settle(std::size_t drive, std::uint64_t grant, bool sent);
    // Renews the live lease held under `token`; refuses otherwise.
    LeaseDecision renew(std::size_t drive, const LeaseToken& token, rtu::Instant now);
    // Gives the lease held under `token` up (no fallback). False otherwise.
    bool release(std::size_t drive, const LeaseToken& token);
    // Who holds a live lease on some drive under another token than `token` (for broadcasts).
    [[nodiscard]] std::optional<Holder> other_holder(const LeaseToken& token) const;

    // Leases that have run out by `now`; each becomes Expired and is returned once. A lease
    // with a grant not yet settled waits: whether it was renewed is not known yet.
    std::vector<Expiry> expire(rtu::Instant now);
    // drivebusd stops: every lease held ends now, run out or not, as if it had.
    std::vector<Expiry> end_all(rtu::Instant now);
    // A lease the last drivebusd held when it ended (lease_record.hpp): Expired now, naming
    // `who`; its fallback is applied as an expiry's is.
    void recovered(std::size_t drive, const Holder& who, rtu::Instant now);
    // The next expiry, if any lease is held (and has no grant unsettled).
    [[nodiscard]] std::optional<rtu::Instant> next_deadline() const;
    // The fallback's write was answered (or not).
    void fallback_result(std::size_t drive, bool ok);

    [[nodiscard]] shm::LeaseStatus status(std::size_t drive) const;
    [[nodiscard]] std::uint64_t expiries() const noexcept { return expiries_; }

    // The leases held now (live or run out but not yet expired), by drive.
    [[nodiscard]] std::vector<HeldLease> held() const;
    // Holds `lease` on its drive as it was held: same holder, token and deadline; this table's
    // length and fallback apply from its next renewal and at its expiry.
    void adopt(const HeldLease& lease);

private:
    // What a grant changes, and what settle() puts back.
    struct Taken {
        Holder holder;
        LeaseToken token{};  // zero unless Held
        rtu::Instant expires{};
        shm::LeaseState state = shm::LeaseState::Free;
        std::uint64_t epoch = 0;  // which change made this state (unique per table)
    };
    struct Grant {
        std::uint64_t id = 0;
        Taken before;                   // the lease as the grant found it
        std::uint64_t epoch_after = 0;  // the change the grant made
    };
    struct Lease : Taken {
        rtu::Duration duration{};
        config::LeaseFallback fallback = config::LeaseFallback::Hold;
        bool fallback_ok = false;
        rtu::Instant expired{};
        std::uint64_t expiries = 0;
        std::vector<Grant> unsettled;  // in the order granted
    };
    // A change to `l`: a new epoch.
    void changed(Lease& l) noexcept { l.epoch = ++epochs_; }
    [[nodiscard]] static bool held_under(const Lease& l, const LeaseToken& token);
    [[nodiscard]] LeaseToken token_for(const LeaseToken& presented);
    void end(std::size_t drive, rtu::Instant now);

    std::vector<Lease> leases_;
    TokenSource tokens_;
    std::uint64_t expiries_ = 0;
    std::uint64_t epochs_ = 0;
};

}  // namespace drivebus::ipc
