// SPDX-License-Identifier: Apache-2.0
#include <grp.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <random>
#include <utility>

#include "bus_impl.hpp"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/service_discovery.hpp"
#include "sys/local.hpp"

namespace drivebus {
iox::capro::IdString_t id(std::string_view text) {
    return {iox::cxx::TruncateToCapacity, std::string(text).c_str()};
}

namespace {

std::uint64_t random_id() {
    std::random_device rd;
    const std::uint64_t r = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
    return (r << 16) ^ static_cast<std::uint64_t>(::getpid()) ^ 1U;
}

}  // namespace

// ---- Bus::Impl ----

Bus::Impl::Impl(std::string bus, ConnectOptions connect_options)
    : name(std::move(bus)), options(std::move(connect_options)), client_id(random_id()) {
    client_name = options.application + "[" + std::to_string(::getpid()) + "]";
    gate->impl = this;
}

namespace {

// What the process keeps until it ends, never freed, and held where LeakSanitizer finds it (a
// pointer it reaches from a global is no leak).
void keep_until_exit(const void* p) {
    static std::mutex mutex;
    // NOLINTNEXTLINE(cppcoreguidelines-owning-memory): never freed, on purpose
    static auto* kept = new std::vector<const void*>();
    if (p != nullptr) {
        const std::lock_guard lock(mutex);
        kept->push_back(p);
    }
}

}  // namespace

Bus::Impl::~Impl() {
    {
        const std::lock_guard lock(gate->mutex);  // after a callback under way
        gate->impl = nullptr;
    }
    // After a Done under way; a send() still inside iceoryx keeps the client port.
    const bool abandoned = sender && sender->stop();
    if (!alive()) {
        keep_until_exit(listener.release());
        keep_until_exit(gate.release());
        // RouDi went with drivebusd: giving the ports back would touch shared memory nobody
        // manages any more (iceoryx aborts on it). The process keeps them until it ends, and
        // the feeds with them (the listener's contexts point into them).
        for (auto& d : drives) {
            keep_until_exit(d->subscriber.release());
            keep_until_exit(d.release());
        }
        keep_until_exit(client.release());
        keep_until_exit(status_subscriber.release());
        return;
    }
    listener.reset();
    for (auto& d : drives) {
        d->subscriber.reset();
    }
    if (abandoned) {
        keep_until_exit(client.release());
    }
    client.reset();
    status_subscriber.reset();
}

namespace {

// A callback on the listener's thread, unless the Impl is going away.
template <typename F>
void through(CallbackGate& gate, F&& f) {
    const std::lock_guard lock(gate.mutex);
    if (gate.impl != nullptr) {
        gate.dispatching = std::this_thread::get_id();
        std::forward<F>(f)(*gate.impl);
        gate.dispatching = std::thread::id{};
    }
}

void status_arrived(iox::popo::Subscriber<shm::BusStatus>* /*unused*/, CallbackGate* gate) {
    through(*gate, [](Bus::Impl& impl) { impl.on_status_sample(); });
}

void snapshot_arrived(iox::popo::Subscriber<shm::DriveSnapshot>* /*unused*/, DriveFeed::Context* context) {
    through(*context->gate, [&](Bus::Impl& impl) { impl.on_drive_sample(*context->feed); });
}

void response_arrived(iox::popo::UntypedClient* /*unused*/, CallbackGate* gate) {
    through(*gate, [](Bus::Impl& impl) { impl.on_response(); });
}

}  // namespace

std::expected<void, Error> Bus::Impl::open() {
    const bool threads = options.delivery == Delivery::Thread;
    if (threads) {
        listener = std::make_unique<iox::popo::Listener>();
    } else if (auto made = open_descriptor(); !made) {
        return std::unexpected(made.error());
    }
    iox::popo::SubscriberOptions status_options;
    status_options.historyRequest = 1;
    status_options.queueCapacity = 4;
    status_subscriber = std::make_unique<iox::popo::Subscriber<shm::BusStatus>>(
        iox::capro::ServiceDescription{id(shm::kService), id(name), id(shm::kStatusEvent)}, status_options);
    if (threads) {
        (void)listener->attachEvent(*status_subscriber, iox::popo::SubscriberEvent::DATA_RECEIVED,
                                    iox::popo::createNotificationCallback(status_arrived, *gate));
        on_status_sample();  // a sample that came before the listener did
    }
    shm::BusStatus first;
    {
        std::unique_lock lock(mutex);
        wait(lock, Clock::now() + options.connect_timeout, [&] { return status.has_value(); });
        if (!status) {
            return std::unexpected(make_error(ErrorKind::NoSuchBus, "drivebusd does not announce bus '" + name +
                                                                        "' (drivebusctl list shows the buses)"));
        }
        first = *status;  // the listener's thread keeps writing it
    }
    const auto group = std::string(shm::view(first.control_group));
    may_request = group.empty() || sys::user_in_group(group);

    for (std::size_t i = 0; i < first.drive_count && i < first.drives.size(); ++i) {
        auto feed = std::make_unique<DriveFeed>();
        feed->name = std::string(shm::view(first.drives[i].name));
        feed->address = first.drives[i].address;
        const auto type = std::string(shm::view(first.drives[i].profile));
        auto profile =
            options.profile_dir ? load_profile(*options.profile_dir / (type + ".toml")) : load_profile_by_type(type);
        if (profile) {
            feed->profile = std::make_shared<const Profile>(std::move(*profile));
        }
        feed->context = {gate.get(), feed.get()};
        iox::popo::SubscriberOptions o;
        o.historyRequest = 1;
        o.queueCapacity = 2;
        feed->subscriber = std::make_unique<iox::popo::Subscriber<shm::DriveSnapshot>>(
            iox::capro::ServiceDescription{id(shm::kService), id(name),
                                           id(std::string(shm::kDriveEventPrefix) + feed->name)},
            o);
        auto* raw = feed.get();
        {
            std::lock_guard lock(mutex);
            drives.push_back(std::move(feed));
        }
        if (threads) {
            (void)listener->attachEvent(*raw->subscriber, iox::popo::SubscriberEvent::DATA_RECEIVED,
                                        iox::popo::createNotificationCallback(snapshot_arrived, raw->context));
            on_drive_sample(*raw);
        }
    }

    if (may_request) {
        iox::popo::ClientOptions o;
        o.responseQueueCapacity = iox::popo::ClientChunkQueueData_t::MAX_CAPACITY;
        client = std::make_unique<iox::popo::UntypedClient>(
            iox::capro::ServiceDescription{id(shm::kService), id(name), id(shm::kRequestEvent)}, o);
    }
    if (may_request && threads) {
        (void)listener->attachEvent(*client, iox::popo::ClientEvent::RESPONSE_RECEIVED,
                                    iox::popo::createNotificationCallback(response_arrived, *gate));
        auto hand_over = [port = client.get()](const shm::Request& r) { return send_request(*port, r); };
        sender = std::make_unique<Sender>(std::move(hand_over), [this](const shm::Request& r, bool sent) {
            if (r.kind == shm::RequestKind::Withdraw) {
                return;  // its answer is the request's own
            }
            {
                std::lock_guard lock(mutex);
                if (auto it = waiting.find(r.correlation); it != waiting.end()) {
                    it->second.handed = sent ? Handed::Sent : Handed::Refused;
                }
            }
            changed.notify_all();
        });
    }
    if (may_request) {
        const auto deadline = Clock::now() + options.connect_timeout;
        while (client->getConnectionState() != iox::ConnectionState::CONNECTED && Clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        if (client->getConnectionState() != iox::ConnectionState::CONNECTED) {
            return std::unexpected(
                make_error(ErrorKind::NoSuchBus, "bus '" + name + "' takes no requests (its server did not answer)"));
        }
    }
    opened = true;
    if (!threads) {
        settle_until = Clock::now() + options.connect_timeout;
        arm_timer(Clock::now());  // polled until every port has connected
    }
    return {};
}

std::size_t Bus::Impl::on_status_sample() {
    std::size_t ran = 0;
    for (;;) {
        auto sample = status_subscriber->take();
        if (sample.has_error()) {
            return ran;
        }
        if (!shm::compatible(*sample.value().get())) {
            continue;
        }
        std::vector<std::function<void(const shm::BusStatus&)>> callbacks;
        {
            std::lock_guard lock(mutex);
            status = *sample.value().get();
            status_time = Clock::now();
            for (const auto& [key, cb] : status_callbacks) {
                callbacks.push_back(cb);
            }
        }
        changed.notify_all();
        for (const auto& cb : callbacks) {
            cb(*sample.value().get());
        }
        ran += callbacks.size();
    }
}

std::size_t Bus::Impl::on_drive_sample(DriveFeed& feed) {
    std::size_t ran = 0;
    for (;;) {
        auto sample = feed.subscriber->take();
        if (sample.has_error()) {
            return ran;
        }
        const auto& s = *sample.value().get();
        if (!shm::compatible(s)) {
            continue;
        }
        std::vector<std::function<void(const shm::DriveSnapshot&)>> callbacks;
        {
            std::lock_guard lock(mutex);
            feed.last = s;
            for (const auto& [key, cb] : feed.callbacks) {
                callbacks.push_back(cb);
            }
        }
        changed.notify_all();
        for (const auto& cb : callbacks) {
            cb(s);
        }
        ran += callbacks.size();
    }
}

void Bus::Impl::on_response() {
    std::vector<shm::Response> got;
    for (;;) {
        auto taken = client->take();
        if (taken.has_error()) {
            break;
        }
        shm::Response r{};
        std::memcpy(&r, taken.value(), sizeof r);
        client->releaseResponse(taken.value());
        got.push_back(r);
    }
    {
        std::lock_guard lock(mutex);
        for (const auto& r : got) {
            // A withdrawal's "not pending" that crosses the request's own answer does not
            // replace it.
            const bool not_pending = r.status == shm::Status::Rejected && r.reason == shm::RejectReason::NotPending;
            if (auto it = waiting.find(r.correlation); it != waiting.end() && !(it->second.response && not_pending)) {
                it->second.response = r;
            }
        }
    }
    changed.notify_all();
}

bool Bus::Impl::alive() const {
    std::lock_guard lock(mutex);
    return status.has_value() && Clock::now() - status_time < options.daemon_silence;
}

DriveFeed* Bus::Impl::feed(std::string_view which) {
    std::lock_guard lock(mutex);
    for (auto& d : drives) {
        if (d->name == which) {
            return d.get();
        }
    }
    return nullptr;
}

void Bus::Impl::wait_for_answer(std::unique_lock<std::mutex>& lock, std::uint64_t correlation,
                                Clock::time_point deadline) {
    changed.wait_until(lock, deadline, [&] {
        const auto& p = waiting.at(correlation);
        return p.response.has_value() || p.handed == Handed::Refused;
    });
}

std::expected<shm::Response, Error> Bus::Impl::call(shm::Request request) {
    if (!client) {
        return std::unexpected(not_permitted());
    }
    if (options.delivery == Delivery::Dispatch) {
        std::optional<std::expected<shm::Response, Error>> result;
        submit(request, [&result](std::expected<shm::Response, Error> r) { result = std::move(r); });
        std::unique_lock lock(mutex);
        wait(lock, Clock::time_point::max(), [&] { return result.has_value(); });  // a time-out ends it
        return std::move(*result);
    }
    const bool own_deadline = prepare(request);
    // The sender's thread hands it to iceoryx: whatever iceoryx waits on, this caller waits no
    // longer than its time-out (sender.hpp). Never with `mutex` held: Done takes it.
    const auto given_up_at = Clock::now() + options.request_timeout;
    sender->post(request);
    std::unique_lock lock(mutex);
    wait_for_answer(lock, request.correlation, given_up_at);
    if (waiting.at(request.correlation).handed == Handed::Refused) {
        waiting.erase(request.correlation);
        return std::unexpected(make_error(ErrorKind::DaemonGone,
                                          "drivebusd is not taking requests on bus '" + name + "' (has it stopped?)"));
    }
    bool answered = waiting.at(request.correlation).response.has_value();
    if (!answered) {
        lock.unlock();
        const bool never_sent = sender->withdraw(request.correlation);
        lock.lock();
        if (never_sent) {
            waiting.erase(request.correlation);
            return std::unexpected(make_error(
                ErrorKind::Withdrawn, "iceoryx did not take the request within " +
                                          std::to_string(options.request_timeout.count()) +
                                          " ms (a client killed while sending may hold its lock): nothing was sent"));
        }
    }
    if (!answered && waiting.at(request.correlation).handed == Handed::Sent) {
        // Given up: withdrawn if it has not reached the wire, and told which happened. The
        // answer is the request's own result if it finished meanwhile.
        shm::Request withdraw = request;
        withdraw.kind = shm::RequestKind::Withdraw;
        lock.unlock();
        sender->post(withdraw);
        lock.lock();
        wait_for_answer(lock, request.correlation, Clock::now() + withdrawal_wait(options.request_timeout));
        answered = waiting.at(request.correlation).response.has_value();
    }
    return conclude(request, own_deadline, answered);
}

}  // namespace drivebus
