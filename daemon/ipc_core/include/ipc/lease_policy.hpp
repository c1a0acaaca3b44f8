// SPDX-License-Identifier: Apache-2.0
// What the ipc side does about control leases, decided without doing it: the policy takes
// events (a command write, a renewal, a release, time passing, a fallback's outcome) and
// returns actions (answer with this, publish the drive's lease again, log this line, write
// this fallback). Pure: time is an argument; tested without RouDi or a bus.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "ipc/lease.hpp"
#include "ipc/lease_record.hpp"
#include "ipc/pending.hpp"
#include "log/log.hpp"
#include "master/result.hpp"
#include "rtu/pdu.hpp"

namespace drivebus::ipc {

struct Note {
    log::Level level = log::Level::Info;
    std::string text;
    std::string drive;  // the drive's name, for the journal's DRIVE= (the text names it too)
};

struct LeaseAction {
    shm::Status status = shm::Status::Ok;  // Ok: allowed (a write goes on; a renewal is answered Ok)
    Holder holder;                         // NotPermitted: who holds it (name and pid, never the token)
    LeaseToken token{};                    // taken: the token for the taker's answer alone
    std::uint32_t lease_ms = 0;            // the length taken or renewed
    bool republish = false;                // the drive's lease snapshot changed
    std::optional<Note> note;
};

struct FallbackAction {
    std::size_t drive = 0;
    Note note;
    std::optional<rtu::RequestAdu> write;  // none for `hold`
};

struct CarriedLease {
    std::string drive;  // the drive's name: a reload may renumber the drives
    HeldLease lease;
    bool unconfirmed = false;  // not held: a fallback the drive has not confirmed, to write again
};

// What a starting drivebusd makes of the leases its predecessor left recorded.
struct Recovery {
    std::vector<FallbackAction> fallbacks;
    std::vector<Note> notes;  // drives no longer configured, and what the file was
};

class LeasePolicy {
public:
    LeasePolicy(const config::BusConfig& bus, TokenSource tokens);

    // A write that touches a command or reference register of `drive` (kBroadcast: a
    // broadcast, refused while any drive's lease is held under another token than the one
    // `who` presents). `who` presents its token; its name and pid are only for display.
    // `grant` (other than 0): the write has yet to reach the wire; settle() says whether it did.
    LeaseAction command(std::size_t drive, const Origin& who, bool take_over, rtu::Instant now,
                        std::uint64_t grant = 0);
    // The write of `grant` reached the wire (`sent`), or was refused before it did: then what it
    // took or renewed is undone, the former holder included (see LeaseTable::settle). A command
    // that reached the wire ends the retries of a fallback the drive had not confirmed: its
    // holder commands the drive now.
    LeaseAction settle(std::size_t drive, std::uint64_t grant, bool sent);
    LeaseAction renew(std::size_t drive, const Origin& who, rtu::Instant now);
    LeaseAction release(std::size_t drive, const Origin& who);
    // Leases run out by `now`, each with what to write to its drive; and the fallbacks their
    // drives have not confirmed whose next try is due (kFirstRetry after the failure, doubling
    // up to kLastRetry), while nobody holds the drive's lease.
    std::vector<FallbackAction> expire(rtu::Instant now);
    // The bus answered a fallback write. A failed one (timed out, refused, the line down) is not
    // dropped: it stays in the record (`unconfirmed`) and is written again until the drive
    // confirms it, a holder commands the drive, or a drivebusd started later applies it.
    LeaseAction fallback_done(std::size_t drive, master::Outcome outcome, bool refused);
    static constexpr rtu::Duration kFirstRetry = std::chrono::seconds(1);
    static constexpr rtu::Duration kLastRetry = std::chrono::seconds(30);

    // drivebusd stops (or a reload drops the bus): every lease held ends now, each with what
    // to write to its drive before the line is let go; a fallback not yet confirmed is written
    // once more.
    std::vector<FallbackAction> surrender(rtu::Instant now);
    // drivebusd starts: every lease `record` names on a drive still configured was held when
    // the last drivebusd ended, and gets that drive's fallback as configured now (Expired,
    // naming its last holder), before anything else goes to the drive.
    Recovery recover(const ReadLeaseRecord& record, rtu::Instant now);
    // What to keep in the bus's lease record now: the leases held, those whose fallback write
    // has not been answered yet, and the fallbacks their drives have not confirmed. Changes
    // with each grant, take-over, release, expiry and fallback answer; never with a renewal.
    [[nodiscard]] std::vector<RecordedLease> record() const;
    // Whether a fallback write is still unanswered.
    [[nodiscard]] bool fallbacks_pending() const;

    // The next expiry, or the next try of an unconfirmed fallback.
    [[nodiscard]] std::optional<rtu::Instant> next_deadline() const;
    [[nodiscard]] shm::LeaseStatus status(std::size_t drive) const { return table_.status(drive); }
    [[nodiscard]] std::uint64_t expiries() const noexcept { return table_.expiries(); }

    // A reload that restarts the bus: the leases held now and the fallbacks not confirmed, by
    // drive name, to be adopted by the restarted bus's policy.
    [[nodiscard]] std::vector<CarriedLease> carry() const;
    // Adopts each carried lease whose drive this bus still has (by name); the others are
    // dropped, each with a line: a drive removed by the reload has no fallback left to run.
    std::vector<Note> adopt(const std::vector<CarriedLease>& leases);

private:
    [[nodiscard]] std::string where(std::size_t drive) const;
    [[nodiscard]] std::string name(std::size_t drive) const;
    [[nodiscard]] std::optional<rtu::RequestAdu> fallback_write(std::size_t drive) const;
    FallbackAction fallback(std::size_t drive, Note note);
    [[nodiscard]] bool retry_waits(std::size_t drive) const;

    // A fallback write that failed: written again until the drive confirms one.
    struct Retry {
        std::string holder;                // whose lease it ended, for the record and the log
        std::uint32_t failures = 0;        // writes failed in a row
        std::optional<rtu::Instant> next;  // the next try (set at the first tick after a failure)
    };
    const config::BusConfig& bus_;
    LeaseTable table_;
    std::vector<bool> pending_;                // by drive: a fallback write submitted and not answered
    std::vector<std::optional<Retry>> retry_;  // by drive: a fallback the drive has not confirmed
};

}  // namespace drivebus::ipc
