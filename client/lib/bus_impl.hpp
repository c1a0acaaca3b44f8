// SPDX-License-Identifier: Apache-2.0
// The state behind a Bus: iceoryx ports, the listener thread that takes samples and responses,
// requests waiting for their response, and the tokens of the leases this Bus took. Nothing here
// renews a lease on its own: only the application's writes and keep_alive() calls do.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <unordered_map>

#include "drivebus/client.hpp"
#include "iceoryx_posh/popo/listener.hpp"
#include "iceoryx_posh/popo/subscriber.hpp"
#include "iceoryx_posh/popo/untyped_client.hpp"
#include "sender.hpp"
#include "sys/posix.hpp"

namespace drivebus {

struct CallbackGate;

struct DriveFeed {
    std::string name;
    std::uint8_t address = 0;
    std::shared_ptr<const Profile> profile;
    std::unique_ptr<iox::popo::Subscriber<shm::DriveSnapshot>> subscriber;
    std::optional<shm::DriveSnapshot> last;  // guarded by Bus::Impl::mutex
    std::map<std::uint64_t, std::function<void(const shm::DriveSnapshot&)>> callbacks;
    struct Context {
        CallbackGate* gate = nullptr;
        DriveFeed* feed = nullptr;
    } context;
};

// The listener's callbacks reach Bus::Impl only through this: ~Impl closes it once a callback
// under way has returned, before anything a callback touches goes away. When drivebusd is gone
// the listener cannot be destroyed and its thread keeps running: the gate and the feeds its
// callbacks name then stay until the process ends, with the ports.
// The gate's mutex is held through a whole dispatch, the user's callbacks included: whoever
// takes it after unregistering a callback knows that callback is not running and will not run
// again (quiesce()).
struct CallbackGate {
    std::mutex mutex;
    Bus::Impl* impl = nullptr;                   // null: closed
    std::atomic<std::thread::id> dispatching{};  // the listener's thread while it dispatches
};

// Returns once no callback is under way (one copied before it was unregistered has returned).
// From a callback itself, at once: it is the dispatch.
inline void quiesce(CallbackGate& gate) {
    if (gate.dispatching.load() == std::this_thread::get_id()) {
        return;
    }
    const std::lock_guard lock(gate.mutex);
}

// Hidden: Bus is exported whole (client/libdrivebus.map, drivebus::Bus::*), its Impl never, and
// that does not rest on a pattern that spells out which names of Bus to leave out.
struct __attribute__((visibility("hidden"))) Bus::Impl {
    Impl(std::string bus, ConnectOptions connect_options);
    ~Impl();
    Impl(const Impl&) = delete;
    Impl& operator=(const Impl&) = delete;
    Impl(Impl&&) = delete;
    Impl& operator=(Impl&&) = delete;

    std::expected<void, Error> open();  // ports, first status, drives
    std::expected<shm::Response, Error> call(shm::Request request);
    // A request's own fields (version, client, deadline, lease token, correlation), and its
    // place among those waiting: whether its deadline is the caller's own (exchange.cpp).
    bool prepare(shm::Request& request);
    // What a request came to, answered or given up; takes it off those waiting. `mutex` held.
    std::expected<shm::Response, Error> conclude(const shm::Request& request, bool own_deadline, bool answered);
    [[nodiscard]] Error not_permitted() const;
    // Waits, `lock` holding `mutex`, until `done()` or `deadline`: on the condition variable
    // (Delivery::Thread) or dispatching meanwhile (Delivery::Dispatch).
    template <typename Pred>
    bool wait(std::unique_lock<std::mutex>& lock, Clock::time_point deadline, Pred done);

    // Delivery::Dispatch (dispatch.cpp).
    std::expected<void, Error> open_descriptor();
    void submit(shm::Request request, Bus::ResponseDone done);
    std::size_t dispatch();
    // Until the descriptor is readable or `deadline`.
    void wait_readable(Clock::time_point deadline) const;
    // Runs `f` in the next dispatch().
    void post(std::function<void()> f);
    // Waits, up to `deadline`, for a request's answer or the sender's word that iceoryx refused
    // it; `lock` holds `mutex`.
    void wait_for_answer(std::unique_lock<std::mutex>& lock, std::uint64_t correlation, Clock::time_point deadline);
    [[nodiscard]] bool alive() const;
    [[nodiscard]] DriveFeed* feed(std::string_view name);

    // Each returns how many callbacks it ran.
    std::size_t on_status_sample();
    std::size_t on_drive_sample(DriveFeed& feed);
    void on_response();

    std::string name;
    ConnectOptions options;
    std::uint64_t client_id = 0;
    std::string client_name;
    bool may_request = false;

    mutable std::mutex mutex;  // everything below
    mutable std::condition_variable changed;
    std::optional<shm::BusStatus> status;
    Clock::time_point status_time{};
    std::vector<std::unique_ptr<DriveFeed>> drives;
    std::map<std::uint64_t, std::function<void(const shm::BusStatus&)>> status_callbacks;
    std::uint64_t next_callback = 1;
    // A request's way: waiting to be handed to iceoryx, handed over, refused by iceoryx; and
    // its answer.
    enum class Handed : std::uint8_t { Not, Sent, Refused };
    struct Pending {
        Handed handed = Handed::Not;
        std::optional<shm::Response> response;
        // Delivery::Dispatch: its completion, and what giving it up takes.
        Bus::ResponseDone done;
        shm::Request request{};
        bool own_deadline = false;
        bool withdrawing = false;     // given up: its withdrawal sent
        Clock::time_point give_up{};  // then: when the withdrawal is given up too
    };
    std::unordered_map<std::uint64_t, Pending> waiting;  // by correlation
    std::uint64_t next_correlation = 1;
    // The tokens of the control leases this Bus took, by drive name, and the latest one, which
    // a request to a drive with none presents (drivebusd then gives a lease it takes that same
    // token). Two writes taking leases at once may get two tokens: each drive keeps its own.
    std::map<std::string, shm::LeaseToken, std::less<>> lease_tokens;
    shm::LeaseToken latest_token{};

    // The client port: requests go out on the sender's thread only, responses come in on the
    // listener's thread only (iceoryx keeps the two halves of a port apart).
    std::unique_ptr<iox::popo::Subscriber<shm::BusStatus>> status_subscriber;
    std::unique_ptr<iox::popo::UntypedClient> client;
    std::unique_ptr<Sender> sender;
    std::unique_ptr<iox::popo::Listener> listener;
    std::unique_ptr<CallbackGate> gate = std::make_unique<CallbackGate>();

    // Delivery::Dispatch: the descriptor (an epoll set of the three below), a timer for the
    // requests' time-outs and for polling while there are no wake-ups, an eventfd for what is
    // ready at once, and the connection to drivebusd's wake-up socket (sys/wake.hpp).
    sys::UniqueFd epoll;
    sys::UniqueFd timer;
    sys::UniqueFd local;
    sys::UniqueFd wake;
    Clock::time_point next_wake_attempt{};
    Clock::time_point settle_until{};  // until every port is connected: polled
    bool opened = false;               // open() has made every port
    std::deque<std::function<void()>> ready;

private:
    void try_wake_connect(Clock::time_point now);
    [[nodiscard]] bool settled() const;
    void arm_timer(Clock::time_point now);
};

template <typename Pred>
bool Bus::Impl::wait(std::unique_lock<std::mutex>& lock, Clock::time_point deadline, Pred done) {
    if (options.delivery == Delivery::Thread) {
        return changed.wait_until(lock, deadline, done);
    }
    // What has arrived since the last dispatch() counts first: a blocking call sees the newest
    // snapshot and status, as with Delivery::Thread (whose listener keeps them current), not
    // what the caller's last dispatch() left.
    lock.unlock();
    dispatch();
    lock.lock();
    for (;;) {
        if (done()) {
            return true;
        }
        if (Clock::now() >= deadline) {
            return false;
        }
        lock.unlock();
        wait_readable(deadline);
        dispatch();
        lock.lock();
    }
}

// `wait` from now, saturated (a caller's Milliseconds::max() waits for ever).
inline Clock::time_point deadline_after(Milliseconds wait) {
    const auto now = Clock::now();
    return wait >= std::chrono::duration_cast<Milliseconds>(Clock::time_point::max() - now) ? Clock::time_point::max()
                                                                                            : now + wait;
}

// Process-wide: the iceoryx runtime, started once with a name unique to this process
// (runtime.cpp).
std::expected<void, Error> ensure_runtime(const std::string& application);
// The buses drivebusd announces, waiting up to `wait` for the first.
std::vector<std::string> discover_buses(std::chrono::milliseconds wait);
// Whether this user is in `group`, as the group database lists its groups (as RouDi asks).
// An iceoryx service, instance or event name.
iox::capro::IdString_t id(std::string_view text);
Error make_error(ErrorKind kind, std::string message);
// A response as an error, when it is one; `what` names the target ("drive pump"), `profile`
// (the drive's, when there is one) explains the register a rejection names.
// How long a withdrawal is waited for, once a request has been given up.
inline Milliseconds withdrawal_wait(Milliseconds request_timeout) {
    return std::clamp(request_timeout, Milliseconds(200), Milliseconds(1000));
}
// Hands a request to iceoryx (loan, copy, send) on this thread: false when iceoryx refused it.
bool send_request(iox::popo::UntypedClient& port, const shm::Request& request);
std::expected<void, Error> check_response(const std::string& what, const shm::Response& response,
                                          const Profile* profile = nullptr);
// A rejection's reason and register, in words.
std::string rejection_text(const shm::Response& response, const Profile* profile);
// A steady_clock time as CLOCK_MONOTONIC nanoseconds (drivebusd's clock for deadlines).
std::int64_t monotonic_ns(Clock::time_point t);

}  // namespace drivebus
