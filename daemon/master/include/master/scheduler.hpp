// SPDX-License-Identifier: Apache-2.0
// What the bus sends next: client requests (writes first, fair between clients), the set-up a
// drive needs, poll groups at their periods, keep-alives inside each drive's Modbus time-out,
// and back-off probes of absent drives. Pure: time is an argument.
#pragma once

#include <cstdint>
#include <deque>
#include <expected>
#include <map>
#include <optional>
#include <vector>

#include "master/bus_plan.hpp"
#include "master/comm_timeout.hpp"
#include "master/result.hpp"
#include "master/setup_plan.hpp"
#include "master/snapshot.hpp"
#include "rtu/limits.hpp"
#include "rtu/pdu.hpp"

namespace drivebus::master {

// Check: the drive's own Modbus time-out read (and written) when it comes online.
enum class JobKind : std::uint8_t { Setup, Client, Poll, KeepAlive, Probe, Check };

// A register window read in one transaction; for an indirect block, `addresses` are the
// registers its slots hold.
struct ReadChunk {
    std::uint16_t start = 0;
    std::uint16_t quantity = 0;
    std::vector<std::uint16_t> addresses;
};

struct ClientRequest {
    std::uint64_t client = 0;       // who asked (for fairness)
    std::uint64_t correlation = 0;  // echoed in the result
    rtu::RequestAdu request;
    // A probe (drivebusctl scan): any address, configured or not, tried once.
    bool probe = false;
    // drivebusd's lease fallback: the drive's own slot, ahead of every client queue and
    // outside the queue limit (one per drive).
    bool fallback = false;
    // Not a request: withdraws the one with this correlation if it is still waiting.
    bool withdraw = false;
    // Not on the wire by then: dropped and answered expired, never sent late.
    std::optional<rtu::Instant> deadline{};
};

struct Job {
    JobKind kind = JobKind::Poll;
    std::size_t drive = 0;  // index into the bus's drives; kNoDrive for a broadcast
    std::size_t group = 0;
    std::size_t chunk = 0;
    std::uint64_t client = 0;
    std::uint64_t correlation = 0;
    rtu::RequestAdu request;
    std::optional<unsigned> retries;         // overrides the bus setting (probes: none)
    std::optional<rtu::Instant> scheduled;   // a poll cycle's first request: when its period made it due
    bool fallback = false;                   // drivebusd's lease fallback (a client job of its own)
    std::optional<rtu::Instant> deadline{};  // a client's: not sent after it
};
inline constexpr std::size_t kNoDrive = static_cast<std::size_t>(-1);

// BlockUnconfirmed: through an indirect block whose selection the drive has not (yet) been
// seen to apply.
enum class SubmitError : std::uint8_t { QueueFull, UnknownDrive, BlockUnconfirmed };

class Scheduler {
public:
    Scheduler(const BusPlan& bus, rtu::Instant start);

    // A client request; validated by the caller. Rejected when the queue is full (a fallback:
    // when its drive's slot is taken).
    std::expected<void, SubmitError> submit(ClientRequest request);
    // The job to send now, if any. With `reads_only`, writes wait (set-up and client writes):
    // a read's echo tells whether the adapter echoes, a write's (FC06) may not.
    [[nodiscard]] std::optional<Job> next(rtu::Instant now, bool reads_only = false);
    // When next() may have something, if nothing is due now.
    [[nodiscard]] std::optional<rtu::Instant> next_due() const;
    // A job finished (the bus runs one at a time: next() is asked only between jobs).
    // Returns the drive whose snapshot is due: its poll cycle completed, or it went absent.
    std::optional<std::size_t> complete(const Job& job, const Result& result, rtu::Instant now);
    // The line went down: everything in flight is abandoned; polls restart when it is back.
    void line_down(rtu::Instant now);
    void line_up(rtu::Instant now);
    // Empties the client queues and returns what they held (the line went down: each waiting
    // request is answered now rather than sent whenever the line comes back).
    [[nodiscard]] std::vector<Job> take_client_jobs();
    // drivebusd stops: from now on only the lease fallbacks go out (no poll, set-up, keep-alive
    // or probe), and the line is let go once they are answered.
    void wind_down() noexcept { fallbacks_only_ = true; }
    [[nodiscard]] bool winding_down() const noexcept { return fallbacks_only_; }
    // Takes the waiting client request `correlation` out of its queue: false when it is not
    // waiting (taken for the wire, finished, or never queued).
    bool withdraw(std::uint64_t correlation);
    // Takes out of the queues the client requests whose deadline has passed by `now`: they are
    // never sent. The list is valid until the next call (its room is kept: no allocation).
    [[nodiscard]] const std::vector<Job>& expire(rtu::Instant now);
    // The earliest deadline of a waiting client request.
    [[nodiscard]] std::optional<rtu::Instant> next_deadline() const;

    [[nodiscard]] std::size_t drive_count() const noexcept { return drives_.size(); }
    // Fills `out` without allocating (the bus thread calls it every poll cycle).
    void snapshot(std::size_t drive, DriveSnapshot& out) const noexcept;
    [[nodiscard]] DriveSnapshot snapshot(std::size_t drive) const noexcept {
        DriveSnapshot s;
        snapshot(drive, s);
        return s;
    }
    [[nodiscard]] Health health(std::size_t drive) const noexcept { return drives_[drive].health; }
    [[nodiscard]] std::size_t queued() const noexcept { return queued_; }
    // The drive at `address`, if configured.
    [[nodiscard]] std::optional<std::size_t> drive_at(rtu::SlaveAddress address) const noexcept;
    [[nodiscard]] const rtu::FunctionLimits& limits(std::size_t drive) const noexcept { return drives_[drive].limits; }
    DriveCounters& counters(std::size_t drive) noexcept { return drives_[drive].counters; }

private:
    struct Group {
        const PollGroup* config = nullptr;
        std::vector<ReadChunk> chunks;
        rtu::Instant next_due{};
        std::optional<std::size_t> cursor;  // next chunk of a cycle in progress
    };
    struct Drive {
        const DrivePlan* config = nullptr;
        rtu::FunctionLimits limits;
        std::vector<Group> groups;
        SetupPlan setup;  // the selectors of its indirect blocks, and the confirmation of the read block
        bool setup_done = true;
        // The blocks return what drivebusd selected: set when a set-up is done, cleared when one
        // fails and when the drive comes back from absence. Client requests through a block
        // wait for it.
        bool blocks_confirmed = true;
        // Where the profile's status word says the drive is tripped, when it has blocks to set
        // up again after a reset (resolved once: watch_fault runs every poll cycle).
        struct FaultFlag {
            std::uint16_t status = 0;
            unsigned bit = 0;
        };
        std::optional<FaultFlag> fault_flag;
        bool faulted = false;                  // the status word's fault bit, as last polled
        std::optional<Health> before_absence;  // Unconfigured or AwaitingReset when it went silent
        rtu::Instant setup_retry{};            // a failed set-up starts again no sooner
        rtu::Duration setup_backoff{};
        Health health = Health::Unknown;
        rtu::Instant last_contact{};
        rtu::Duration backoff{};
        rtu::Instant next_probe{};
        RegisterTable values;
        DriveCounters counters;
        std::uint64_t sequence = 0;
        std::optional<Job> fallback;  // sent before anything else on the bus
        CommTimeoutCheck comm;        // its own Modbus time-out, read when it comes online
    };

    [[nodiscard]] std::optional<Job> next_client_read();
    [[nodiscard]] std::optional<Job> take_client(
        std::initializer_list<std::map<std::uint64_t, std::deque<Job>>*> order);
    [[nodiscard]] std::optional<Job> next_fallback();
    [[nodiscard]] std::optional<Job> next_setup(rtu::Instant now);
    // A set-up did not hold: the drive is unconfigured (or awaits a reset) until one does.
    void setup_failed(std::size_t drive, rtu::Instant now, SetupState state);
    // A set-up step finished; returns the drive if its health changed.
    std::optional<std::size_t> setup_step(const Job& job, const Result& result, rtu::Instant now);
    [[nodiscard]] std::optional<Job> next_check();
    // A step of a drive's time-out check finished; returns the drive when the check did.
    std::optional<std::size_t> check_step(const Job& job, const Result& result);
    [[nodiscard]] bool through_block(std::size_t drive, const rtu::RequestAdu& request) const noexcept;
    void watch_fault(std::size_t drive, const ReadChunk& chunk, const Result& result);
    [[nodiscard]] std::optional<Job> next_poll(rtu::Instant now);
    [[nodiscard]] std::optional<Job> next_keep_alive(rtu::Instant now);
    [[nodiscard]] std::optional<Job> next_probe(rtu::Instant now);
    [[nodiscard]] Job read_job(JobKind kind, std::size_t drive, std::size_t group, std::size_t chunk) const;
    void mark_absent(std::size_t drive, rtu::Instant now);
    void mark_present(std::size_t drive, rtu::Instant now);
    void store(std::size_t drive, const ReadChunk& chunk, const Result& result);

    const BusPlan& bus_;
    std::vector<Drive> drives_;
    bool line_up_ = true;
    bool fallbacks_only_ = false;
    // Client queues per client, writes and reads apart; served round-robin.
    std::map<std::uint64_t, std::deque<Job>> writes_;
    std::map<std::uint64_t, std::deque<Job>> reads_;
    std::uint64_t last_client_ = 0;
    bool last_was_read_ = false;  // the last job was a client read: a due poll goes next
    std::size_t queued_ = 0;
    std::vector<Job> expired_;  // expire()'s answer
};

// The read transactions a poll group needs, within the drive's limits.
[[nodiscard]] std::vector<ReadChunk> plan_reads(const PollGroup& group, const Profile& profile,
                                                const rtu::FunctionLimits& limits);
// The drive's function limits, from its profile.
[[nodiscard]] rtu::FunctionLimits limits_of(const Profile& profile);

}  // namespace drivebus::master
