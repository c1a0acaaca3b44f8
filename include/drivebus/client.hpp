// SPDX-License-Identifier: Apache-2.0
// libdrivebus: how an application reaches the drives that drivebusd runs.
//
//   auto bus = drivebus::Bus::connect("line1");
//   auto pump = bus->drive("pump");                       // by name, or "3" by address
//   auto speed = pump->read("FD00");                      // one request on the bus
//   pump->write("FA01", {5000});                          // takes the drive's control lease
//   for (;;) {                                            // the application's control loop
//       auto snap = pump->wait_snapshot(std::chrono::milliseconds(100));  // the latest polled values
//       ...
//       if (!pump->keep_alive()) { ... }                  // the loop is alive: renew the lease
//   }
//
// Everything returns std::expected: nothing here throws. A Bus is safe to use from several
// threads; callbacks run on the library's own thread and must not block.
//
// An application with its own event loop connects with Delivery::Dispatch instead: the library
// then starts no thread, the loop watches bus.descriptor() and calls bus.dispatch() when it is
// readable, and every callback (snapshots, statuses, the async_ requests' completions) runs in
// dispatch(), on the loop's thread (examples/app/poll_loop.cpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "drivebus/profile.hpp"
#include "drivebus/shm.hpp"

#if defined(DRIVEBUS_CLIENT_BUILD)
#define DRIVEBUS_API __attribute__((visibility("default")))
#else
#define DRIVEBUS_API
#endif

namespace drivebus {

using Clock = std::chrono::steady_clock;
using Milliseconds = std::chrono::milliseconds;

enum class ErrorKind : std::uint8_t {
    Exception,     // the drive answered with a Modbus exception (Error::exception)
    Timeout,       // the drive did not answer
    BadFrame,      // the reply was spoiled (CRC, framing, parity, echo)
    Rejected,      // drivebusd refused the request before the bus (Error::reason)
    QueueFull,     // the bus's queue is full: retry later
    BusDown,       // the bus's line is not open
    NotPermitted,  // another client holds the control lease, or not in the control group
    NotRunning,    // no drivebusd (no RouDi) to connect to
    NoSuchBus,     // drivebusd runs but does not announce that bus
    DaemonGone,    // drivebusd went silent after we connected
    // drivebusd answered neither the request in time nor its withdrawal: its outcome is
    // unknown (a write may have been applied: read it back)
    NoReply,
    InvalidArgument,  // bad input on this side: unknown register name, value too large
    Unsupported,      // the drive's profile does not define what was asked (a helper)
    LateReply,        // the drive answered, but only after the response time-out (Error::message says how late)
    // Not answered in time, and withdrawn before it reached the wire: never sent (safe to retry).
    Withdrawn,
    // Not answered in time, and it had reached the wire when given up: its outcome is unknown
    // (a write may have been applied: read it back).
    OutcomeUnknown,
    // Its deadline (WriteOptions::deadline) passed before it reached the wire: never sent.
    Expired,
};

[[nodiscard]] DRIVEBUS_API std::string_view to_string(ErrorKind kind) noexcept;
// A Modbus exception code (Error::exception) in words: 2 -> "illegal data address"; a code
// Modbus does not define -> "undefined exception code".
[[nodiscard]] DRIVEBUS_API std::string_view exception_name(std::uint8_t code) noexcept;

struct Error {
    ErrorKind kind = ErrorKind::InvalidArgument;
    std::string message;  // one line, says what to do
    std::uint8_t exception = 0;
    shm::RejectReason reason = shm::RejectReason::None;
    // NotPermitted by a lease: who holds it, as that client names itself, and its pid (empty,
    // 0: this process presented no valid token and nobody else holds it).
    std::string lease_holder;
    std::int32_t lease_holder_pid = 0;
};

// Where a Bus's callbacks run, and who waits for what arrives.
enum class Delivery : std::uint8_t {
    // On the library's own threads (a listener and a sender): callbacks run there, and blocking
    // calls wait for them.
    Thread,
    // On the caller's thread, in Bus::dispatch(), which the application calls whenever
    // Bus::descriptor() is readable: the library starts no thread. Such a Bus belongs to the
    // thread of that loop. Its blocking calls (read(), write(), wait_snapshot(), status(), ...)
    // take what has arrived first and dispatch while they wait, so other callbacks may run
    // inside them.
    Dispatch,
};

struct ConnectOptions {
    std::string application = "drivebus-client";  // shown in drivebusd's logs
    // How long a request may take (queueing and retries included). Past it the request is
    // withdrawn, and the error says which happened: Withdrawn (never sent), OutcomeUnknown
    // (it had reached the wire), or the request's own result if it finished meanwhile. Each
    // request carries that time as its deadline: drivebusd never sends it after it.
    Milliseconds request_timeout{2000};
    // No bus status for this long: DaemonGone. drivebusd publishes at least once a second.
    Milliseconds daemon_silence{3000};
    // How long connect() waits for the bus to be announced.
    Milliseconds connect_timeout{2000};
    // Where drive profiles are found (register names, units, fault names); default search path.
    std::optional<std::filesystem::path> profile_dir;
    Delivery delivery = Delivery::Thread;
};

struct Identity {
    std::string vendor;
    std::string product_code;
    std::string revision;
};

struct WriteOptions {
    bool take_over = false;  // take the control lease from another client
    // How long from the call the write may still go out: not on the wire by then, drivebusd
    // drops it (Expired: never sent, never late). None: the request time-out alone bounds it.
    std::optional<Milliseconds> deadline;
};

// A callback registration; unregisters when destroyed. Once reset() (or the destructor) has
// returned, the callback is not running and is never called again, so what it touches may go;
// it waits for a call under way to return. Called from within a callback, it returns at once.
// So never reset a subscription while holding a lock its callback takes.
class DRIVEBUS_API Subscription {
public:
    Subscription() = default;
    explicit Subscription(std::function<void()> cancel) : cancel_(std::move(cancel)) {}
    ~Subscription() { reset(); }
    Subscription(Subscription&& other) noexcept : cancel_(std::move(other.cancel_)) { other.cancel_ = nullptr; }
    Subscription& operator=(Subscription&& other) noexcept {
        if (this != &other) {
            reset();
            cancel_ = std::move(other.cancel_);
            other.cancel_ = nullptr;
        }
        return *this;
    }
    Subscription(const Subscription&) = delete;
    Subscription& operator=(const Subscription&) = delete;
    void reset() {
        if (cancel_) {
            cancel_();
            cancel_ = nullptr;
        }
    }

private:
    std::function<void()> cancel_;
};

class Drive;

class DRIVEBUS_API Bus {
public:
    // Connects to the bus `bus` of a running drivebusd (empty: the only bus announced). Fails
    // fast with NotRunning when no drivebusd runs, and NoSuchBus when it does not announce it.
    static std::expected<Bus, Error> connect(std::string_view bus = {}, ConnectOptions options = {});
    // The buses drivebusd announces.
    static std::expected<std::vector<std::string>, Error> list(ConnectOptions options = {});

    ~Bus();
    Bus(Bus&&) noexcept;
    Bus& operator=(Bus&&) noexcept;
    Bus(const Bus&) = delete;
    Bus& operator=(const Bus&) = delete;

    [[nodiscard]] const std::string& name() const noexcept;
    // The latest bus status (waits up to `wait` for the first one).
    [[nodiscard]] std::expected<shm::BusStatus, Error> status(Milliseconds wait = Milliseconds(0)) const;
    // False once drivebusd has been silent for ConnectOptions::daemon_silence.
    [[nodiscard]] bool daemon_alive() const;
    // The drive by name or by address ("3").
    [[nodiscard]] std::expected<Drive, Error> drive(std::string_view name_or_address) const;
    // Whether this process may send requests (member of the bus's control group).
    [[nodiscard]] bool can_request() const;
    // Calls `callback` with each bus status.
    [[nodiscard]] Subscription on_status(std::function<void(const shm::BusStatus&)> callback) const;

    // A raw request: fills correlation, and client, client_name, pid and lease_token where the
    // caller left them zero (lease_token: the one this Bus holds for that drive), waits for the
    // response. A response that took a lease gives this Bus its token.
    [[nodiscard]] std::expected<shm::Response, Error> request(shm::Request request) const;
    // Delivery::Dispatch: sends the request as request() does and returns at once; `done` runs
    // in a later dispatch() with what request() would have returned, exactly once, unless the
    // Bus (with every Drive of it) is destroyed first: its pending completions are then
    // destroyed uncalled (a `done` that holds a Drive or Bus of this bus keeps it from going
    // until it has run). Delivery::Thread: `done` runs at once with InvalidArgument.
    using ResponseDone = std::function<void(std::expected<shm::Response, Error>)>;
    void async_request(shm::Request request, ResponseDone done) const;

    // Delivery::Dispatch: the descriptor an event loop watches for reading (poll, epoll, an
    // asio or Qt socket notifier, asyncio's add_reader); when it is readable, call dispatch().
    // -1 with Delivery::Thread.
    [[nodiscard]] int descriptor() const noexcept;
    // Delivery::Dispatch: takes what has arrived and runs the callbacks it is for, on this
    // thread; gives up the requests whose time has passed (their completions run too). Never
    // waits. Returns how many callbacks ran. With Delivery::Thread: nothing, 0.
    std::size_t dispatch() const;

    // A write to every drive (address 0): no reply, the bus waits the turnaround.
    [[nodiscard]] std::expected<void, Error> broadcast(std::uint16_t address,
                                                       std::span<const std::uint16_t> values) const;

    // This Bus's client id, as it tells drivebusd (logs, fairness). It grants nothing: what lets
    // a request act under a control lease is the lease's secret token, which drivebusd gives
    // this Bus alone when one of its writes takes the lease, and which the library presents
    // with every request it sends.
    [[nodiscard]] std::uint64_t client_id() const noexcept;

    struct Impl;

private:
    explicit Bus(std::shared_ptr<Impl> impl);
    std::shared_ptr<Impl> impl_;
    friend class Drive;
};

class DRIVEBUS_API Drive {
public:
    [[nodiscard]] const std::string& name() const noexcept;
    [[nodiscard]] std::uint8_t address() const noexcept;
    // The drive's profile, when it could be loaded (names, units, limits).
    [[nodiscard]] const Profile* profile() const noexcept;

    // A register by profile name ("FA01", "W450") or number ("0xFA01", "64001").
    [[nodiscard]] std::expected<std::uint16_t, Error> resolve(std::string_view reg) const;
    [[nodiscard]] const RegisterInfo* info(std::uint16_t address) const noexcept;

    // The latest snapshot; waits up to `wait` for one newer than `after` (sequence).
    [[nodiscard]] std::expected<shm::DriveSnapshot, Error> wait_snapshot(Milliseconds wait,
                                                                         std::uint64_t after = 0) const;
    // Calls `callback` on each new snapshot (on the library's thread).
    [[nodiscard]] Subscription on_snapshot(std::function<void(const shm::DriveSnapshot&)> callback) const;

    // Requests on the bus.
    [[nodiscard]] std::expected<std::vector<std::uint16_t>, Error> read(std::uint16_t address,
                                                                        std::uint16_t count = 1) const;
    [[nodiscard]] std::expected<std::vector<std::uint16_t>, Error> read(std::string_view reg,
                                                                        std::uint16_t count = 1) const;
    [[nodiscard]] std::expected<void, Error> write(std::uint16_t address, std::span<const std::uint16_t> values,
                                                   WriteOptions options = {}) const;
    [[nodiscard]] std::expected<void, Error> write(std::string_view reg, std::span<const std::uint16_t> values,
                                                   WriteOptions options = {}) const;
    [[nodiscard]] std::expected<Identity, Error> identify() const;

    // The same, completed by callback in a later Bus::dispatch() (Delivery::Dispatch; see
    // Bus::async_request for Delivery::Thread).
    using ReadDone = std::function<void(std::expected<std::vector<std::uint16_t>, Error>)>;
    using Done = std::function<void(std::expected<void, Error>)>;
    void async_read(std::uint16_t address, std::uint16_t count, ReadDone done) const;
    void async_write(std::uint16_t address, std::span<const std::uint16_t> values, Done done,
                     WriteOptions options = {}) const;
    void async_keep_alive(Done done) const;
    void async_release_control(Done done) const;

    // The control lease lives only as long as the application shows it is alive: each write to
    // the drive's command or reference renews it, and so does keep_alive(). Nothing else does:
    // no thread of the library renews it, so a control loop that hangs or deadlocks stops
    // renewing, and drivebusd applies the drive's fallback once the lease time (the drive's
    // `lease`, 1 s by default) has passed since the last renewal. Call keep_alive() from the
    // control loop itself, at least a few times per lease time (a quarter of it leaves room
    // for a late iteration), never from a timer thread of its own.
    //
    // Renews this process's lease on the drive (the LeaseRenew request). NotPermitted when it
    // holds none: it ran out (the fallback was applied), another client took it over, or no
    // write took it; a write to the command or reference takes a fresh one.
    [[nodiscard]] std::expected<void, Error> keep_alive() const;
    // Gives up the control lease without the fallback.
    [[nodiscard]] std::expected<void, Error> release_control() const;
    // Whether this Bus holds a token for the drive's lease: one of its writes took it (directly
    // or through an indirect block). It may have run out or been taken over since.
    [[nodiscard]] bool holds_control() const;

private:
    Drive(std::shared_ptr<Bus::Impl> bus, std::string name, std::uint8_t address,
          std::shared_ptr<const Profile> profile);
    std::shared_ptr<Bus::Impl> bus_;
    std::string name_;
    std::uint8_t address_ = 0;
    std::shared_ptr<const Profile> profile_;
    friend class Bus;
};

}  // namespace drivebus
