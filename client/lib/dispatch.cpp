// SPDX-License-Identifier: Apache-2.0
// Delivery::Dispatch: a Bus run by the application's own event loop, with no thread of the
// library's. The loop watches one descriptor, an epoll set of:
//   - the connection to drivebusd's wake-up socket (sys/wake.hpp): a byte each time drivebusd
//     has published or answered something;
//   - a timerfd: the requests' time-outs, and polling while there are no wake-ups (the ports
//     still connecting, or drivebusd's socket unreachable);
//   - an eventfd: completions ready without a round trip (a request refused at once).
// dispatch() then takes from shared memory what the listener thread takes in Delivery::Thread,
// and gives up the requests whose time has passed the way call() does (a withdrawal, then the
// request's own answer or the verdict).
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <utility>

#include "bus_impl.hpp"
#include "sys/wake.hpp"

namespace drivebus {
namespace {

// While there are no wake-ups, shared memory is looked at this often.
constexpr auto kPollWithoutWakeups = std::chrono::milliseconds(10);
// While the ports connect (a subscription's first sample comes with no wake-up).
constexpr auto kPollWhileSettling = std::chrono::milliseconds(2);
// How often a lost wake-up connection is tried again.
constexpr auto kWakeRetry = std::chrono::milliseconds(500);

std::expected<void, sys::SysError> watch(int epoll, int fd) {
    epoll_event event{};
    event.events = EPOLLIN;
    event.data.fd = fd;
    if (auto added = sys::posix_call("epoll_ctl", [&] { return ::epoll_ctl(epoll, EPOLL_CTL_ADD, fd, &event); });
        !added) {
        return std::unexpected(added.error());
    }
    return {};
}

Error descriptor_error(const sys::SysError& e) {
    return make_error(ErrorKind::InvalidArgument, "cannot make the bus's descriptor: " + e.message());
}

}  // namespace

std::expected<void, Error> Bus::Impl::open_descriptor() {
    auto made_epoll = sys::posix_call("epoll_create1", [] { return ::epoll_create1(EPOLL_CLOEXEC); });
    auto made_timer =
        sys::posix_call("timerfd_create", [] { return ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC); });
    auto made_local = sys::posix_call("eventfd", [] { return ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC); });
    for (const auto* made : {&made_epoll, &made_timer, &made_local}) {
        if (!*made) {
            return std::unexpected(descriptor_error(made->error()));
        }
    }
    epoll.reset(*made_epoll);
    timer.reset(*made_timer);
    local.reset(*made_local);
    for (const int fd : {timer.get(), local.get()}) {
        if (auto ok = watch(epoll.get(), fd); !ok) {
            return std::unexpected(descriptor_error(ok.error()));
        }
    }
    const auto now = Clock::now();
    // Before the ports: what is published once they exist comes with a wake-up.
    try_wake_connect(now);
    settle_until = now + options.connect_timeout;
    arm_timer(now);
    return {};
}

void Bus::Impl::try_wake_connect(Clock::time_point now) {
    next_wake_attempt = now + kWakeRetry;
    auto connected = sys::wake_connect(sys::wake_socket_path(name));
    if (!connected) {
        return;  // polled on the timer meanwhile
    }
    if (!watch(epoll.get(), connected->get())) {
        return;
    }
    wake = std::move(*connected);
}

bool Bus::Impl::settled() const {
    if (!opened || status_subscriber->getSubscriptionState() != iox::SubscribeState::SUBSCRIBED) {
        return false;  // open() has not made every port yet
    }
    for (const auto& d : drives) {
        if (d->subscriber->getSubscriptionState() != iox::SubscribeState::SUBSCRIBED) {
            return false;
        }
    }
    return !client || client->getConnectionState() == iox::ConnectionState::CONNECTED;
}

void Bus::Impl::arm_timer(Clock::time_point now) {
    auto at = Clock::time_point::max();
    {
        std::lock_guard lock(mutex);
        for (const auto& [correlation, p] : waiting) {
            if (p.done) {
                at = std::min(at, p.give_up);
            }
        }
    }
    if (!wake) {
        at = std::min(at, now + kPollWithoutWakeups);
    }
    if (settle_until != Clock::time_point{}) {
        if (now < settle_until && !settled()) {
            at = std::min(at, now + kPollWhileSettling);
        } else {
            settle_until = {};
        }
    }
    itimerspec spec{};
    if (at != Clock::time_point::max()) {
        const auto ns = std::max<std::int64_t>(monotonic_ns(at), 1);
        spec.it_value.tv_sec = ns / 1'000'000'000;
        spec.it_value.tv_nsec = ns % 1'000'000'000;
    }
    (void)::timerfd_settime(timer.get(), TFD_TIMER_ABSTIME, &spec, nullptr);  // an instant past fires at once
}

void Bus::Impl::post(std::function<void()> f) {
    {
        std::lock_guard lock(mutex);
        ready.push_back(std::move(f));
    }
    const std::uint64_t one = 1;
    (void)::write(local.get(), &one, sizeof one);  // fails only when signalled already
}

void Bus::Impl::submit(shm::Request request, Bus::ResponseDone done) {
    if (!client) {
        post([done = std::move(done), e = not_permitted()] { done(std::unexpected(e)); });
        return;
    }
    const bool own_deadline = prepare(request);
    {
        std::lock_guard lock(mutex);
        auto& p = waiting.at(request.correlation);
        p.done = std::move(done);
        p.request = request;
        p.own_deadline = own_deadline;
        p.give_up = Clock::now() + options.request_timeout;
    }
    const bool sent = send_request(*client, request);
    {
        std::lock_guard lock(mutex);
        auto& p = waiting.at(request.correlation);
        p.handed = sent ? Handed::Sent : Handed::Refused;
        if (!sent) {
            auto refused = std::move(p.done);
            waiting.erase(request.correlation);
            ready.push_back(
                [refused = std::move(refused),
                 e = make_error(ErrorKind::DaemonGone, "drivebusd is not taking requests on bus '" + name +
                                                           "' (has it stopped?)")] { refused(std::unexpected(e)); });
        }
    }
    if (!sent) {
        const std::uint64_t one = 1;
        (void)::write(local.get(), &one, sizeof one);
    }
    arm_timer(Clock::now());
}

void Bus::Impl::wait_readable(Clock::time_point deadline) const {
    const auto left = deadline - Clock::now();
    const auto ms = std::chrono::ceil<Milliseconds>(std::min<Clock::duration>(left, std::chrono::seconds(1)));
    pollfd p{.fd = epoll.get(), .events = POLLIN, .revents = 0};
    (void)::poll(&p, 1, static_cast<int>(std::max<Milliseconds::rep>(ms.count(), 0)));  // EINTR: the caller looks again
}

std::size_t Bus::Impl::dispatch() {
    // Callbacks run under the gate, as the listener's do: a Subscription reset on another thread
    // waits for a callback under way. A blocking call inside a callback dispatches again, nested.
    std::uint64_t count = 0;
    (void)::read(local.get(), &count, sizeof count);  // EAGAIN: not signalled
    (void)::read(timer.get(), &count, sizeof count);  // EAGAIN: not fired
    const bool nested = gate->dispatching.load() == std::this_thread::get_id();
    std::unique_lock<std::mutex> gated;
    if (!nested) {
        gated = std::unique_lock(gate->mutex);
        gate->dispatching = std::this_thread::get_id();
    }
    auto now = Clock::now();
    if (wake && !sys::wake_drain(wake.get())) {
        (void)::epoll_ctl(epoll.get(), EPOLL_CTL_DEL, wake.get(), nullptr);
        wake.reset();  // drivebusd closed it: it stopped, or a reload dropped the bus
        next_wake_attempt = now + kWakeRetry;
    } else if (!wake && now >= next_wake_attempt) {
        try_wake_connect(now);
    }

    std::size_t ran = on_status_sample();
    for (std::size_t i = 0;; ++i) {
        DriveFeed* feed = nullptr;
        {
            std::lock_guard lock(mutex);
            if (i >= drives.size()) {
                break;
            }
            feed = drives[i].get();
        }
        ran += on_drive_sample(*feed);
    }

    std::vector<std::function<void()>> completions;
    std::vector<shm::Request> withdraw;
    if (client) {
        on_response();
        now = Clock::now();
        std::lock_guard lock(mutex);
        std::vector<std::uint64_t> ended;
        for (auto& [correlation, p] : waiting) {
            if (!p.done || p.handed != Handed::Sent) {
                continue;  // a blocking call's, in Delivery::Thread; or not sent yet
            }
            if (p.response || (p.withdrawing && now >= p.give_up)) {
                ended.push_back(correlation);
            } else if (!p.withdrawing && now >= p.give_up) {
                // Given up: withdrawn if it has not reached the wire, and told which happened.
                p.withdrawing = true;
                p.give_up = now + withdrawal_wait(options.request_timeout);
                shm::Request w = p.request;
                w.kind = shm::RequestKind::Withdraw;
                withdraw.push_back(w);
            }
        }
        for (const auto correlation : ended) {
            auto& p = waiting.at(correlation);
            auto done = std::move(p.done);
            const auto request = p.request;
            const bool answered = p.response.has_value();
            auto result = conclude(request, p.own_deadline, answered);
            completions.emplace_back([done = std::move(done), result = std::move(result)] { done(result); });
        }
    }
    for (const auto& w : withdraw) {
        (void)send_request(*client, w);  // refused: the withdrawal's wait ends it all the same
    }
    {
        std::lock_guard lock(mutex);
        while (!ready.empty()) {
            completions.push_back(std::move(ready.front()));
            ready.pop_front();
        }
    }
    arm_timer(Clock::now());
    for (auto& c : completions) {
        c();
    }
    ran += completions.size();
    if (!nested) {
        gate->dispatching = std::thread::id{};
    }
    return ran;
}

}  // namespace drivebus
