#include "ipc/bus_service.hpp"

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fmt/format.h>
#include <optional>
#include <unordered_map>
#include <vector>

#include "bus/bus_loop.hpp"
#include "iceoryx_posh/popo/publisher.hpp"
#include "iceoryx_posh/popo/subscriber.hpp"
#include "iceoryx_posh/popo/untyped_server.hpp"
#include "iceoryx_posh/popo/user_trigger.hpp"
#include "iceoryx_posh/popo/wait_set.hpp"
#include "ipc/admission.hpp"
#include "ipc/convert.hpp"
#include "ipc/lease.hpp"
#include "log/log.hpp"
#include "sys/posix.hpp"

namespace drivebus::ipc {
namespace {

using iox::popo::RequestHeader;

iox::capro::IdString_t id(std::string_view text) {
    return {iox::cxx::TruncateToCapacity, std::string(text).c_str()};
}

iox::capro::ServiceDescription service(const std::string& bus, std::string_view event) {
    return {id(shm::kService), id(bus), id(event)};
}

constexpr auto kStatusInterval = std::chrono::seconds(1);
constexpr auto kStatusCheck = std::chrono::milliseconds(100);

// A request handed to the bus loop, waiting for its result.
struct Pending {
    std::optional<RequestHeader> header;  // empty: drivebusd's own (a lease fallback)
    std::uint64_t correlation = 0;        // the client's
    std::uint64_t client = 0;
    std::string client_name;
    shm::RequestKind kind = shm::RequestKind::Read;
    std::size_t drive = kBroadcast;
    std::uint32_t lease_ms = 0;
};

struct DriveChannel {
    explicit DriveChannel(const iox::capro::ServiceDescription& description, const iox::popo::PublisherOptions& options)
        : publisher(description, options) {}
    std::mutex mutex;  // the bus thread and the intake thread both publish
    iox::popo::Publisher<shm::DriveSnapshot> publisher;
    shm::DriveSnapshot last{};
    bool have_last = false;
    std::uint64_t sequence = 0;
};

iox::popo::PublisherOptions history_one() {
    iox::popo::PublisherOptions options;
    options.historyCapacity = 1;
    return options;
}

}  // namespace

struct BusService::Impl {
    Impl(const config::BusConfig& b, const Layout& layout)
        : bus(b),
          control_group(layout.control_group),
          leases(b),
          status_publisher(service(b.name, shm::kStatusEvent), history_one()),
          server(service(b.name, shm::kRequestEvent), iox::popo::ServerOptions{}),
          health(b.drives.size(), shm::DriveHealth::Unknown) {
        for (const auto& d : b.drives) {
            drives.push_back(std::make_unique<DriveChannel>(
                service(b.name, std::string(shm::kDriveEventPrefix) + d.name), history_one()));
        }
    }

    const config::BusConfig& bus;
    std::string control_group;
    bus::BusLoop* loop = nullptr;

    std::mutex lease_mutex;
    LeaseTable leases;

    std::vector<std::unique_ptr<DriveChannel>> drives;
    iox::popo::Publisher<shm::BusStatus> status_publisher;  // intake thread only
    std::mutex server_mutex;
    iox::popo::UntypedServer server;

    std::mutex pending_mutex;
    std::unordered_map<std::uint64_t, Pending> pending;
    std::uint64_t next_id = 1;

    std::mutex health_mutex;
    std::vector<shm::DriveHealth> health;
    std::atomic<std::uint64_t> served{0};

    iox::popo::UserTrigger wake;
    std::atomic<bool> running{false};
    std::thread intake;

    // ---- publication ----

    void publish(DriveChannel& ch) {  // ch.mutex held
        ch.last.sequence = ++ch.sequence;
        ch.last.published_ns = monotonic_ns(sys::now());
        auto sample = ch.publisher.loan();
        if (sample.has_error()) {
            log::warning(fmt::format("bus {}: no shared memory for a snapshot", bus.name));
            return;
        }
        std::memcpy(static_cast<void*>(sample.value().get()), &ch.last, sizeof ch.last);
        sample.value().publish();
    }

    void republish_lease(std::size_t drive) {
        shm::LeaseStatus status;
        {
            std::lock_guard lock(lease_mutex);
            status = leases.status(drive);
        }
        auto& ch = *drives.at(drive);
        std::lock_guard lock(ch.mutex);
        if (!ch.have_last) {
            fill_snapshot_shell(drive, ch.last);
            ch.have_last = true;
        }
        ch.last.lease = status;
        publish(ch);
    }

    void fill_snapshot_shell(std::size_t drive, shm::DriveSnapshot& s) const {
        const auto& d = bus.drives.at(drive);
        s.version = shm::kPayloadVersion;
        s.size = sizeof(shm::DriveSnapshot);
        shm::assign(s.bus, bus.name);
        shm::assign(s.name, d.name);
        shm::assign(s.profile, d.profile ? d.profile->type : "");
        s.address = d.address;
    }

    void publish_status() {
        const auto status = loop->status();
        std::vector<shm::DriveHealth> h;
        {
            std::lock_guard lock(health_mutex);
            h = health;
        }
        auto sample = status_publisher.loan();
        if (sample.has_error()) {
            return;
        }
        auto& out = *sample.value().get();
        fill_status(bus, status, h, out);
        shm::assign(out.control_group, control_group);
        out.counters.requests_served = served.load();
        {
            std::lock_guard lock(lease_mutex);
            out.counters.lease_expiries = leases.expiries();
        }
        sample.value().publish();
    }

    // ---- requests ----

    void answer(Pending& p, const std::function<void(shm::Response&)>& fill) {
        ++served;
        if (!p.header) {
            return;
        }
        std::lock_guard lock(server_mutex);
        auto loaned = server.loan(&*p.header, sizeof(shm::Response), alignof(shm::Response));
        if (loaned.has_error()) {
            return;  // the client has gone: nothing to answer
        }
        auto* r = new (loaned.value()) shm::Response{};
        r->size = sizeof(shm::Response);
        r->correlation = p.correlation;
        r->lease_ms = p.lease_ms;
        fill(*r);
        (void)server.send(loaned.value());
    }

    void answer_status(Pending& p, shm::Status status, shm::RejectReason reason = shm::RejectReason::None,
                       std::uint16_t address = 0, std::uint64_t holder = 0) {
        answer(p, [&](shm::Response& r) {
            r.status = status;
            r.reason = reason;
            r.register_address = address;
            r.lease_holder = holder;
        });
    }

    void take_requests() {
        for (;;) {
            std::optional<Pending> p;
            shm::Request request;
            {
                std::lock_guard lock(server_mutex);
                auto taken = server.take();
                if (taken.has_error()) {
                    return;
                }
                const void* payload = taken.value();
                const auto* header = RequestHeader::fromPayload(payload);
                const auto size = header->getChunkHeader()->userPayloadSize();
                request = shm::Request{};
                std::memcpy(&request, payload, std::min<std::size_t>(size, sizeof request));
                if (size != sizeof request) {
                    request.size = static_cast<std::uint32_t>(size);
                }
                // The header only routes the response: keep a copy, give the chunk back now.
                p.emplace(Pending{std::move(*const_cast<RequestHeader*>(header)), request.correlation,
                                  request.client, std::string(shm::view(request.client_name)), request.kind});
                server.releaseRequest(payload);
            }
            handle(std::move(*p), request);
        }
    }

    void handle(Pending p, const shm::Request& request) {
        auto admitted = admit(bus, request);
        if (!admitted) {
            log::info(fmt::format("bus {}: request from {} rejected: {}", bus.name, p.client_name,
                                  admitted.error().why));
            answer_status(p, shm::Status::Rejected, admitted.error().reason, admitted.error().register_address);
            return;
        }
        p.drive = admitted->drive;
        if (!admitted->on_wire) {
            handle_lease(p);
            return;
        }
        if (admitted->touches_control && !check_lease(p, request)) {
            return;
        }
        if (!loop->up()) {
            answer_status(p, shm::Status::BusDown);
            return;
        }
        submit(std::move(p), admitted->request, request.kind == shm::RequestKind::Probe);
    }

    void submit(Pending p, const rtu::RequestAdu& adu, bool probe = false) {
        std::uint64_t id = 0;
        const auto client = p.client;
        {
            std::lock_guard lock(pending_mutex);
            id = next_id++;
            pending.emplace(id, std::move(p));
        }
        auto submitted = loop->submit(master::ClientRequest{client, id, adu, probe});
        if (submitted) {
            return;
        }
        Pending back;
        {
            std::lock_guard lock(pending_mutex);
            auto it = pending.find(id);
            back = std::move(it->second);
            pending.erase(it);
        }
        answer_status(back, submitted.error() == master::SubmitError::QueueFull ? shm::Status::QueueFull
                                                                                : shm::Status::Rejected,
                      submitted.error() == master::SubmitError::QueueFull ? shm::RejectReason::None
                                                                          : shm::RejectReason::UnknownDrive);
    }

    // A write to the command or reference: the writer must hold (or take) the lease.
    bool check_lease(Pending& p, const shm::Request& request) {
        const auto now = sys::now();
        if (p.drive == kBroadcast) {
            std::optional<std::uint64_t> other;
            {
                std::lock_guard lock(lease_mutex);
                other = leases.other_holder(p.client);
            }
            if (other) {
                answer_status(p, shm::Status::NotPermitted, shm::RejectReason::None, request.start, *other);
                return false;
            }
            return true;
        }
        LeaseDecision d;
        {
            std::lock_guard lock(lease_mutex);
            d = leases.acquire(p.drive, p.client, p.client_name, (request.flags & shm::kFlagTakeOver) != 0, now);
        }
        const auto& name = bus.drives[p.drive].name;
        if (!d.allowed) {
            log::info(fmt::format("bus {} drive {}: {} may not command it: {} holds the control lease", bus.name, name,
                                  p.client_name, d.holder_name));
            answer_status(p, shm::Status::NotPermitted, shm::RejectReason::None, request.start, d.holder);
            return false;
        }
        if (d.taken_over) {
            log::notice(fmt::format("bus {} drive {}: {} took the control lease over", bus.name, name, p.client_name));
        }
        p.lease_ms = d.lease_ms;
        if (d.changed) {
            // A renewal only moves the expiry: subscribers hear of new holders, not of each write.
            republish_lease(p.drive);
        }
        return true;
    }

    void handle_lease(Pending& p) {
        const auto now = sys::now();
        bool ok = false;
        std::uint64_t holder = 0;
        {
            std::lock_guard lock(lease_mutex);
            if (p.kind == shm::RequestKind::LeaseRelease) {
                ok = leases.release(p.drive, p.client);
            } else {
                const auto d = leases.renew(p.drive, p.client, now);
                ok = d.allowed;
                holder = d.holder;
                p.lease_ms = d.lease_ms;
            }
        }
        if (p.kind == shm::RequestKind::LeaseRelease && ok) {
            log::info(fmt::format("bus {} drive {}: {} released the control lease", bus.name,
                                  bus.drives[p.drive].name, p.client_name));
            republish_lease(p.drive);
        }
        answer_status(p, ok ? shm::Status::Ok : shm::Status::NotPermitted, shm::RejectReason::None, 0, holder);
    }

    // ---- lease expiry ----

    void expire_leases() {
        std::vector<Expiry> expired;
        {
            std::lock_guard lock(lease_mutex);
            expired = leases.expire(sys::now());
        }
        for (const auto& e : expired) {
            const auto& d = bus.drives[e.drive];
            log::warning(fmt::format("bus {} drive {}: the control lease of {} ran out; fallback: {}", bus.name,
                                     d.name, e.holder_name, config::to_string(e.fallback)));
            if (e.fallback != config::LeaseFallback::Hold) {
                const auto& control = *d.profile->control;
                const auto* command = d.profile->find(control.command);
                const auto word = e.fallback == config::LeaseFallback::Stop ? *control.stop : *control.freewheel;
                Pending p;
                p.client_name = "drivebusd fallback";
                p.kind = shm::RequestKind::Write;
                p.drive = e.drive;
                submit(std::move(p), {d.address, rtu::WriteSingleRegister{*command->address, word}});
            }
            republish_lease(e.drive);
        }
    }

    void fallback_done(const Pending& p, const master::Result& result) {
        const bool ok = result.outcome == master::Outcome::Ok;
        {
            std::lock_guard lock(lease_mutex);
            leases.fallback_result(p.drive, ok);
        }
        if (!ok) {
            log::error(fmt::format("bus {} drive {}: the fallback write failed: {}", bus.name,
                                   bus.drives[p.drive].name, master::to_string(result.outcome)));
        }
        republish_lease(p.drive);
    }

    // ---- the intake thread ----

    void run() {
        iox::popo::WaitSet<> waitset;
        (void)waitset.attachEvent(server, iox::popo::ServerEvent::REQUEST_RECEIVED);
        (void)waitset.attachEvent(wake);
        auto next_status = sys::now();
        bool last_up = false;
        std::vector<shm::DriveHealth> last_health;
        while (running.load()) {
            take_requests();
            expire_leases();
            const auto now = sys::now();
            const bool up = loop->up();
            std::vector<shm::DriveHealth> h;
            {
                std::lock_guard lock(health_mutex);
                h = health;
            }
            // Once a second, and at once when the line or a drive's health changes.
            if (now >= next_status || up != last_up || h != last_health) {
                publish_status();
                next_status = now + kStatusInterval;
            }
            last_up = up;
            last_health = std::move(h);
            auto until = std::min(next_status, now + kStatusCheck);
            {
                std::lock_guard lock(lease_mutex);
                if (const auto deadline = leases.next_deadline()) {
                    until = std::min(until, *deadline);
                }
            }
            const auto wait = std::max(until - sys::now(), rtu::Duration(std::chrono::microseconds(50)));
            (void)waitset.timedWait(iox::units::Duration::fromNanoseconds(
                static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(wait).count())));
        }
    }
};

BusService::BusService(const config::BusConfig& bus, const Layout& layout)
    : impl_(std::make_unique<Impl>(bus, layout)) {}

BusService::~BusService() {
    stop();
}

void BusService::on_snapshot(const master::DriveSnapshot& snapshot) {
    auto& impl = *impl_;
    std::size_t index = 0;
    while (index < impl.bus.drives.size() && impl.bus.drives[index].name != snapshot.name) {
        ++index;
    }
    if (index == impl.bus.drives.size()) {
        return;
    }
    {
        std::lock_guard lock(impl.health_mutex);
        impl.health[index] = to_shm(snapshot.health);
    }
    shm::LeaseStatus lease;
    {
        std::lock_guard lock(impl.lease_mutex);
        lease = impl.leases.status(index);
    }
    auto& ch = *impl.drives[index];
    std::lock_guard lock(ch.mutex);
    fill_snapshot(snapshot, ch.last);
    ch.have_last = true;
    ch.last.lease = lease;
    impl.publish(ch);
}

void BusService::on_result(std::uint64_t correlation, const master::Result& result) {
    auto& impl = *impl_;
    Pending p;
    {
        std::lock_guard lock(impl.pending_mutex);
        auto it = impl.pending.find(correlation);
        if (it == impl.pending.end()) {
            return;
        }
        p = std::move(it->second);
        impl.pending.erase(it);
    }
    if (!p.header) {
        impl.fallback_done(p, result);
        return;
    }
    impl.answer(p, [&](shm::Response& r) { fill_response(result, r); });
}

std::size_t BusService::drives_online() const {
    std::lock_guard lock(impl_->health_mutex);
    return static_cast<std::size_t>(std::ranges::count(impl_->health, shm::DriveHealth::Online));
}

std::optional<int> bus_served_elsewhere(const std::string& bus) {
    // A subscriber with history gets the other daemon's last status at once if it publishes.
    iox::popo::SubscriberOptions options;
    options.historyRequest = 1;
    options.queueCapacity = 1;
    iox::popo::Subscriber<shm::BusStatus> subscriber(service(bus, shm::kStatusEvent), options);
    const auto deadline = sys::now() + std::chrono::milliseconds(300);
    while (sys::now() < deadline) {
        auto sample = subscriber.take();
        if (!sample.has_error() && shm::compatible(*sample.value().get())) {
            return sample.value()->daemon_pid;
        }
        if (subscriber.getSubscriptionState() == iox::SubscribeState::WAIT_FOR_OFFER) {
            return std::nullopt;  // nobody offers it
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return std::nullopt;
}

void BusService::start(bus::BusLoop& loop, const std::function<void()>& on_thread) {
    impl_->loop = &loop;
    impl_->running = true;
    impl_->intake = std::thread([this, on_thread] {
        (void)::pthread_setname_np(::pthread_self(), ("ipc " + impl_->bus.name).substr(0, 15).c_str());
        if (on_thread) {
            on_thread();
        }
        impl_->run();
    });
}

void BusService::stop() {
    if (impl_->intake.joinable()) {
        impl_->running = false;
        impl_->wake.trigger();
        impl_->intake.join();
    }
}

}  // namespace drivebus::ipc
