// SPDX-License-Identifier: Apache-2.0
// The shared-memory contract between drivebusd and its clients: the payloads published and
// exchanged through iceoryx. Every type here is fixed-size and trivially copyable (no
// pointers, no heap) and starts with a version; a reader checks `version` and `size` before
// trusting the rest. Changing a layout means bumping kPayloadVersion.
//
// Services (iceoryx service / instance / event):
//   ("drivebus", <bus>, "drive/<name>")  DriveSnapshot, history 1
//   ("drivebus", <bus>, "status")        BusStatus, history 1, at least once a second
//   ("drivebus", <bus>, "requests")      request server: Request in, Response out
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <type_traits>

namespace drivebus::shm {

inline constexpr std::uint32_t kPayloadVersion = 5;
inline constexpr std::string_view kService = "drivebus";
inline constexpr std::string_view kStatusEvent = "status";
inline constexpr std::string_view kRequestEvent = "requests";
inline constexpr std::string_view kDriveEventPrefix = "drive/";

inline constexpr std::size_t kNameSize = 32;     // bus and drive names, NUL-terminated
inline constexpr std::size_t kProfileSize = 16;  // profile type, NUL-terminated
inline constexpr std::size_t kGroupSize = 32;    // Unix group names
inline constexpr std::size_t kDeviceSize = 64;   // the bus's serial device path, NUL-terminated
inline constexpr std::size_t kMaxSnapshotRegisters = 128;
inline constexpr std::size_t kMaxDrivesPerBus = 32;
inline constexpr std::size_t kMaxReadWords = 125;   // FC03
inline constexpr std::size_t kMaxWriteWords = 123;  // FC16
inline constexpr std::size_t kIdentObjectSize = 64;

// A fixed char buffer as a string.
template <std::size_t N>
[[nodiscard]] std::string_view view(const std::array<char, N>& text) noexcept {
    return {text.data(), ::strnlen(text.data(), N)};
}
// Copies `from` (truncated to N-1 characters) and pads with NULs.
template <std::size_t N>
void assign(std::array<char, N>& text, std::string_view from) noexcept {
    text.fill('\0');
    std::memcpy(text.data(), from.data(), from.size() < N ? from.size() : N - 1);
}

// The secret a client gets when it takes a drive's control lease: 128 random bits, handed in
// the Response to its own request alone, and presented by its later requests (renew, write
// under the lease, release). All zero: none.
using LeaseToken = std::array<std::uint64_t, 2>;

enum class DriveHealth : std::uint8_t {
    Unknown = 0,  // not polled yet, or the line is down (nothing can answer)
    Online = 1,
    Absent = 2,         // stopped answering; probed with back-off
    Unconfigured = 3,   // answers, but its set-up failed, did not read back, or its read block
                        // returns something else: not polled, retried with back-off
    AwaitingReset = 4,  // answers; drivebusd wrote selectors it applies only after a reset (ATV21:
                        // F870-F879): not polled until the block shows them applied; power-cycle it
};

enum class Fallback : std::uint8_t { Hold = 0, Stop = 1, Freewheel = 2 };

enum class LeaseState : std::uint8_t {
    Free = 0,     // nobody commands the drive
    Held = 1,     // `holder` commands it and renews in time
    Expired = 2,  // the holder stopped renewing; the fallback was applied
};

struct RegisterSample {
    std::uint16_t address = 0;
    std::uint16_t value = 0;
    std::uint8_t valid = 0;  // 0: never read, or the last read of it failed
    std::array<std::uint8_t, 3> reserved{};
    std::int64_t time_ns = 0;  // CLOCK_MONOTONIC end of the reply the value came from
};

struct DriveCounters {
    std::uint64_t requests = 0;  // attempts sent
    std::uint64_t replies = 0;   // valid replies, exceptions included
    std::uint64_t timeouts = 0;
    std::uint64_t bad_frames = 0;
    std::uint64_t retries = 0;
    std::uint64_t exceptions = 0;
    std::uint64_t absent_transitions = 0;
    std::uint64_t late = 0;  // replies that came after their attempt timed out: discarded
};

struct LeaseStatus {
    // Who holds it (Held: the holder; Expired: the last one; empty when free): the client's own
    // name and pid, for people to read. Never the token: knowing who holds it grants nothing.
    std::array<char, kNameSize> holder{};
    std::int32_t holder_pid = 0;
    std::uint32_t reserved_pid = 0;
    std::int64_t expires_ns = 0;  // CLOCK_MONOTONIC; 0 when free
    std::uint32_t duration_ms = 0;
    LeaseState state = LeaseState::Free;
    Fallback fallback = Fallback::Hold;
    std::uint8_t fallback_ok = 0;  // the fallback write was acknowledged by the drive
    std::uint8_t reserved = 0;
    std::int64_t expired_ns = 0;  // when it last expired; 0: never
    std::uint64_t expiries = 0;   // how often it has expired since drivebusd started
};

// The drive's own Modbus time-out (its profile's [safety]: ATV21 F803, and F603 for what it does
// when it fires), as drivebusd found it when the drive last came online.
enum class CommTimeoutState : std::uint8_t {
    Unknown = 0,       // the profile names none, or not read yet
    Read = 1,          // `timeout_ms` is what the drive holds
    Written = 2,       // drivebusd wrote the configured `wanted_ms` (comm_timeout) and read it back
    ReadRefused = 3,   // it could not be read: `exception` (0: no valid reply)
    WriteRefused = 4,  // writing `wanted_ms` got `exception` (0: no valid reply); `timeout_ms` still held
    ReadBack = 5,      // written `wanted_ms`, it reads back `timeout_ms`
};
enum class CommTimeoutVerdict : std::uint8_t {
    None = 0,     // not known
    Fine = 1,     // on, and longer than `gap_ms`
    Off = 2,      // off: if the line or drivebusd dies, the drive runs on at its last command
    MayFire = 3,  // not longer than `gap_ms` (or nothing bounds it): the drive may trip on a healthy line
};

struct CommTimeout {
    CommTimeoutState state = CommTimeoutState::Unknown;
    CommTimeoutVerdict verdict = CommTimeoutVerdict::None;
    std::uint8_t exception = 0;
    std::uint8_t action_valid = 0;  // `action` was read
    std::uint16_t raw = 0;          // the time-out register as read
    std::uint16_t action = 0;       // the fault behaviour register as read (ATV21: F603)
    std::uint32_t timeout_ms = 0;   // `raw` in ms; 0: off
    std::uint32_t wanted_ms = 0;    // the configured comm_timeout; 0: none
    // The longest drivebusd may leave between two requests to the drive; 0: nothing bounds it.
    std::uint32_t gap_ms = 0;
    std::uint32_t reserved = 0;
};

struct DriveSnapshot {
    std::uint32_t version = kPayloadVersion;
    std::uint32_t size = 0;      // sizeof(DriveSnapshot) of the writer
    std::uint64_t sequence = 0;  // +1 per snapshot of this drive
    std::int64_t published_ns = 0;
    std::array<char, kNameSize> bus{};
    std::array<char, kNameSize> name{};
    std::array<char, kProfileSize> profile{};
    std::uint8_t address = 0;
    DriveHealth health = DriveHealth::Unknown;
    std::uint16_t register_count = 0;
    std::array<std::uint8_t, 4> reserved{};
    DriveCounters counters;
    LeaseStatus lease;
    std::array<RegisterSample, kMaxSnapshotRegisters> registers{};  // sorted by address
    CommTimeout comm_timeout;

    [[nodiscard]] const RegisterSample* find(std::uint16_t reg) const noexcept {
        for (std::size_t i = 0; i < register_count && i < registers.size(); ++i) {
            if (registers[i].address == reg) {
                return &registers[i];
            }
        }
        return nullptr;
    }
};

struct Timing {
    std::uint64_t count = 0;
    std::int64_t mean_ns = 0;
    std::int64_t max_ns = 0;
};

struct BusCounters {
    std::uint64_t transmissions = 0;
    std::uint64_t replies = 0;
    std::uint64_t timeouts = 0;
    std::uint64_t crc_errors = 0;
    std::uint64_t gap_errors = 0;
    std::uint64_t parity_errors = 0;
    std::uint64_t overflows = 0;
    std::uint64_t noise = 0;
    std::uint64_t foreign = 0;
    std::uint64_t malformed = 0;
    std::uint64_t echo_mismatches = 0;
    std::uint64_t retries = 0;
    std::uint64_t broadcasts = 0;
    std::uint64_t queue_rejections = 0;
    std::uint64_t line_down = 0;
    std::uint64_t exceptions = 0;
    std::uint64_t requests_served = 0;  // client requests answered, rejections included
    std::uint64_t lease_expiries = 0;
    std::uint64_t late_replies = 0;  // replies after their attempt timed out: discarded
    std::uint64_t held_replies = 0;  // replies the kernel handed over late, still complete in time
    std::uint64_t sync_probes = 0;   // requests sent to prove a slave in step after a reply went missing
    std::uint64_t mute_reopens = 0;  // the port reopened: open, and every drive silent for mute_reopen
};

// Every counter of BusCounters, in its order, for code that maps them by name (X(name) each):
// drivebusd copies the bus thread's counters into it by name, drivebusctl names them.
// clang-format off: one counter a line (the formatter would wrap them differently each run)
#define DRIVEBUS_SHM_BUS_COUNTERS(X) \
    X(transmissions) \
    X(replies) \
    X(timeouts) \
    X(crc_errors) \
    X(gap_errors) \
    X(parity_errors) \
    X(overflows) \
    X(noise) \
    X(foreign) \
    X(malformed) \
    X(echo_mismatches) \
    X(retries) \
    X(broadcasts) \
    X(queue_rejections) \
    X(line_down) \
    X(exceptions) \
    X(requests_served) \
    X(lease_expiries) \
    X(late_replies) \
    X(held_replies) \
    X(sync_probes) \
    X(mute_reopens)
// clang-format on
#define DRIVEBUS_SHM_COUNT_ONE(name) +1
static_assert(sizeof(BusCounters) == sizeof(std::uint64_t) * (0 DRIVEBUS_SHM_BUS_COUNTERS(DRIVEBUS_SHM_COUNT_ONE)),
              "DRIVEBUS_SHM_BUS_COUNTERS must list every field of shm::BusCounters");
#undef DRIVEBUS_SHM_COUNT_ONE

struct DriveEntry {
    std::array<char, kNameSize> name{};
    std::array<char, kProfileSize> profile{};
    std::uint8_t address = 0;
    DriveHealth health = DriveHealth::Unknown;
    // Its snapshot's comm_timeout, for a list of the drives.
    CommTimeoutState comm_timeout_state = CommTimeoutState::Unknown;
    CommTimeoutVerdict comm_timeout_verdict = CommTimeoutVerdict::None;
    std::uint32_t comm_timeout_ms = 0;
};
static_assert(sizeof(DriveEntry) == 56, "DriveEntry keeps its size (its last six bytes were reserved)");

struct BusStatus {
    std::uint32_t version = kPayloadVersion;
    std::uint32_t size = 0;
    std::uint64_t sequence = 0;
    std::int64_t published_ns = 0;
    std::int32_t daemon_pid = 0;
    std::uint32_t baud = 0;
    std::array<char, kNameSize> bus{};
    std::array<char, kDeviceSize> device{};
    std::array<char, 4> format{};  // "8E1"
    std::uint8_t up = 0;           // the line is open
    std::uint8_t drive_count = 0;
    std::uint8_t drives_online = 0;
    std::uint8_t reserved = 0;
    // Who may send requests: members of this group (empty: anyone who can reach RouDi).
    std::array<char, kGroupSize> control_group{};
    BusCounters counters;
    Timing reply_latency;  // request off the wire to the reply's last character
    Timing extra_gap;      // silence before a request beyond the t3.5 required
    std::array<DriveEntry, kMaxDrivesPerBus> drives{};
};

enum class RequestKind : std::uint8_t {
    Read = 0,          // FC03
    Write = 1,         // FC06 for one word, FC16 for more (or `function` if set)
    Identify = 2,      // FC43/14, basic objects
    Broadcast = 3,     // a write to address 0: no reply
    LeaseRenew = 4,    // keeps the caller's control lease on the drive
    LeaseRelease = 5,  // gives it up: no fallback
    Probe = 6,         // FC03 of one word at `start` to `address`, configured or not: who answers?
    // Gives up the caller's request with this `correlation` (and `client`): withdrawn if it
    // has not reached the wire (answered Withdrawn, never sent), else answered Sent (its outcome
    // is still to come) or, if it has just finished, with its result.
    Withdraw = 7,
};

inline constexpr std::uint8_t kFlagTakeOver = 0x01;  // take the control lease from its holder

struct Request {
    std::uint32_t version = kPayloadVersion;
    std::uint32_t size = 0;
    std::uint64_t correlation = 0;  // echoed in the response
    std::uint64_t client = 0;       // the client's id (per process, random): grants nothing
    // The token of the control lease the client holds (Response::lease_token), or zero: what
    // lets a write under the lease, a LeaseRenew or a LeaseRelease through.
    LeaseToken lease_token{};
    RequestKind kind = RequestKind::Read;
    std::uint8_t flags = 0;
    std::uint8_t address = 0;   // the drive, when `drive` is empty
    std::uint8_t function = 0;  // Write/Broadcast: 6 or 16; 0 lets drivebusd choose
    std::uint16_t start = 0;    // first register
    std::uint16_t count = 0;    // words to read, or words in `values`
    std::int32_t pid = 0;       // the client's process, as it says: shown as the lease's holder
    std::uint32_t reserved = 0;
    std::array<char, kNameSize> drive{};
    std::array<char, kNameSize> client_name{};  // for logs: "pump-control[1234]"
    std::array<std::uint16_t, kMaxWriteWords> values{};
    // Not on the wire by this CLOCK_MONOTONIC time (ns), the request is dropped and answered
    // Expired, never sent late; 0: none. Past already when drivebusd takes it: Expired at once.
    std::int64_t deadline_ns = 0;
};

enum class Status : std::uint8_t {
    Ok = 0,
    Exception = 1,     // the drive answered with Modbus exception `exception`
    Timeout = 2,       // no reply on any attempt
    BadFrame = 3,      // CRC, framing, parity or echo error on the last attempt
    Rejected = 4,      // failed validation, never sent: see `reason`
    QueueFull = 5,     // the bus's request queue is full: try again later
    BusDown = 6,       // the line is not open
    NotPermitted = 7,  // another client holds the drive's control lease
    Late = 8,          // every attempt timed out and the drive answered after it: see `late_us`
    Withdrawn = 9,     // withdrawn (RequestKind::Withdraw) before it reached the wire: never sent
    Sent = 10,         // to a Withdraw: the request had reached the wire; its outcome is unknown
    Expired = 11,      // its deadline (Request::deadline_ns) passed before it reached the wire: never sent
};

enum class RejectReason : std::uint8_t {
    None = 0,
    UnknownDrive = 1,
    UnknownRegister = 2,
    ReadOnly = 3,
    WriteOnly = 4,
    Quantity = 5,          // count 0, above the function's or the profile's limit
    ValueOutOfRange = 6,   // outside the profile's min/max
    Unsupported = 7,       // the function is not supported by that drive (profile)
    Malformed = 8,         // wrong version or size, unknown kind
    DaemonOwned = 9,       // drivebusd owns the register: a selector of an indirect block, a set-up write
    BlockNotSetUp = 10,    // through an indirect block, or a slot of it, that drivebusd has not set up
    NotPending = 11,       // a Withdraw of a request drivebusd does not hold: answered, or never received
    BlockNotApplied = 12,  // through an indirect block the drive has not been seen to apply: it awaits a
                           // reset, or its set-up did not hold (the drive's health says which)
};

struct Response {
    std::uint32_t version = kPayloadVersion;
    std::uint32_t size = 0;
    std::uint64_t correlation = 0;
    Status status = Status::Ok;
    std::uint8_t exception = 0;  // Modbus exception code for Status::Exception
    RejectReason reason = RejectReason::None;
    std::uint8_t attempts = 0;
    std::uint16_t register_address = 0;  // the register a rejection is about
    std::uint16_t count = 0;             // words in `values`
    std::uint32_t lease_ms = 0;          // this request took or renewed a lease of this length
    std::uint32_t late_us = 0;           // Late: how long after the request the latest reply came
    std::int64_t reply_ns = 0;           // CLOCK_MONOTONIC end of the reply
    // This request took the lease (lease_ms > 0 and not zero): the token to present from now
    // on. Only in the answer to the request that took it.
    LeaseToken lease_token{};
    // NotPermitted: who holds the lease (name and pid as that client gave them).
    std::array<char, kNameSize> lease_holder{};
    std::int32_t lease_holder_pid = 0;
    std::uint32_t reserved_holder = 0;
    std::array<std::uint16_t, kMaxReadWords> values{};
    // Identify: vendor name, product code, revision.
    std::array<std::array<char, kIdentObjectSize>, 3> identity{};
};

static_assert(std::is_trivially_copyable_v<DriveSnapshot>);
static_assert(std::is_trivially_copyable_v<BusStatus>);
static_assert(std::is_trivially_copyable_v<Request>);
static_assert(std::is_trivially_copyable_v<Response>);
static_assert(std::is_standard_layout_v<DriveSnapshot> && std::is_standard_layout_v<BusStatus>);
static_assert(std::is_standard_layout_v<Request> && std::is_standard_layout_v<Response>);

// Whether a payload read from shared memory has the layout this code was built with.
template <typename T>
[[nodiscard]] bool compatible(const T& payload) noexcept {
    return payload.version == kPayloadVersion && payload.size == sizeof(T);
}

[[nodiscard]] constexpr std::string_view to_string(Status status) noexcept {
    switch (status) {
    case Status::Ok: return "ok";
    case Status::Exception: return "exception";
    case Status::Timeout: return "timeout";
    case Status::BadFrame: return "bad frame";
    case Status::Rejected: return "rejected";
    case Status::QueueFull: return "queue full";
    case Status::BusDown: return "bus down";
    case Status::NotPermitted: return "not permitted";
    case Status::Late: return "late reply";
    case Status::Withdrawn: return "withdrawn";
    case Status::Sent: return "sent";
    case Status::Expired: return "expired";
    }
    return "unknown";
}
[[nodiscard]] constexpr std::string_view to_string(RejectReason reason) noexcept {
    switch (reason) {
    case RejectReason::None: return "none";
    case RejectReason::UnknownDrive: return "unknown drive";
    case RejectReason::UnknownRegister: return "unknown register";
    case RejectReason::ReadOnly: return "read-only register";
    case RejectReason::WriteOnly: return "write-only register";
    case RejectReason::Quantity: return "quantity out of range";
    case RejectReason::ValueOutOfRange: return "value out of range";
    case RejectReason::Unsupported: return "function not supported by the drive";
    case RejectReason::Malformed: return "malformed request";
    case RejectReason::DaemonOwned: return "owned by drivebusd";
    case RejectReason::BlockNotSetUp: return "indirect block not set up by drivebusd";
    case RejectReason::NotPending: return "no such request pending";
    case RejectReason::BlockNotApplied:
        return "the drive has not applied the indirect block's selectors yet (it awaits a reset, or its "
               "set-up did not hold: see its health and drivebusd's log); read the registers one by one "
               "meanwhile";
    }
    return "unknown";
}
[[nodiscard]] constexpr std::string_view to_string(DriveHealth health) noexcept {
    switch (health) {
    case DriveHealth::Unknown: return "unknown";
    case DriveHealth::Online: return "online";
    case DriveHealth::Absent: return "absent";
    case DriveHealth::Unconfigured: return "unconfigured";
    case DriveHealth::AwaitingReset: return "awaiting reset";
    }
    return "unknown";
}
[[nodiscard]] constexpr std::string_view to_string(CommTimeoutState state) noexcept {
    switch (state) {
    case CommTimeoutState::Unknown: return "unknown";
    case CommTimeoutState::Read: return "read";
    case CommTimeoutState::Written: return "written";
    case CommTimeoutState::ReadRefused: return "read refused";
    case CommTimeoutState::WriteRefused: return "write refused";
    case CommTimeoutState::ReadBack: return "read back otherwise";
    }
    return "unknown";
}
[[nodiscard]] constexpr std::string_view to_string(CommTimeoutVerdict verdict) noexcept {
    switch (verdict) {
    case CommTimeoutVerdict::None: return "unknown";
    case CommTimeoutVerdict::Fine: return "fine";
    case CommTimeoutVerdict::Off: return "off";
    case CommTimeoutVerdict::MayFire: return "may fire";
    }
    return "unknown";
}
[[nodiscard]] constexpr std::string_view to_string(Fallback fallback) noexcept {
    switch (fallback) {
    case Fallback::Hold: return "hold";
    case Fallback::Stop: return "stop";
    case Fallback::Freewheel: return "freewheel";
    }
    return "unknown";
}
[[nodiscard]] constexpr std::string_view to_string(LeaseState state) noexcept {
    switch (state) {
    case LeaseState::Free: return "free";
    case LeaseState::Held: return "held";
    case LeaseState::Expired: return "expired";
    }
    return "unknown";
}

}  // namespace drivebus::shm
