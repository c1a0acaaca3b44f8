// SPDX-License-Identifier: Apache-2.0
#include "ipc/bus_service.hpp"

#include <pthread.h>
#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <array>
#include <chrono>
#include <stdexcept>
#include <thread>

#include "iceoryx_posh/popo/subscriber.hpp"
#include "ipc/intake.hpp"
#include "ipc/lease_policy.hpp"
#include "ipc/lease_record_file.hpp"
#include "ipc/lease_token.hpp"
#include "ipc/note_log.hpp"
#include "ipc/publisher.hpp"
#include "ipc/service.hpp"
#include "log/log.hpp"
#include "sys/event_fd.hpp"
#include "sys/event_loop.hpp"
#include "sys/wake.hpp"

namespace drivebus::ipc {
namespace {

constexpr auto kStatusInterval = std::chrono::seconds(1);
// How soon a change of the line (up, down) reaches the status.
constexpr auto kStatusCheck = std::chrono::milliseconds(100);
// The most applications woken on their own event loops (sys/wake.hpp); more poll on a timer.
constexpr std::size_t kWakeConnections = 256;

// The bus's wake-up socket, or none when it cannot be made (applications on their own event
// loops then poll on a timer): the reason is logged.
std::shared_ptr<sys::WakeServer> open_wakers(const config::BusConfig& bus, const Layout& layout) {
    const auto path = sys::wake_socket_path(bus.name);
    auto server = sys::WakeServer::listen(path, layout.grouped ? layout.segments.front().reader_group : std::string{},
                                          kWakeConnections);
    if (!server) {
        log::warning(
            fmt::format("bus {}: no wake-up socket at {} ({}): applications on their own event loops "
                        "poll shared memory on a timer instead",
                        bus.name, path, server.error().message()));
        return nullptr;
    }
    return std::make_shared<sys::WakeServer>(std::move(*server));
}

}  // namespace

struct BusService::Impl {
    Impl(const config::BusConfig& b, const Layout& layout, bus::BusLoop& l, std::shared_ptr<Intake::Server> server,
         std::shared_ptr<sys::WakeServer> carried_wakers)
        : bus(b),
          loop(l),
          leases(b, random_tokens()),
          publisher(b, layout),
          // The record is declared after the intake; the journal runs only once requests come.
          intake(b, l, leases, std::move(server), [this] { record.keep(leases.record()); }),
          record(b),
          stop_fd("eventfd for bus " + b.name + "'s ipc thread"),
          wind_fd("eventfd for bus " + b.name + "'s wind-down"),
          wakers(carried_wakers ? std::move(carried_wakers) : open_wakers(b, layout)) {}

    const config::BusConfig& bus;
    bus::BusLoop& loop;
    LeasePolicy leases;
    Publisher publisher;
    Intake intake;
    LeaseRecordFile record;
    sys::EventFd stop_fd;
    sys::EventFd wind_fd;
    std::shared_ptr<sys::WakeServer> wakers;  // null: none could be made
    std::thread thread;
    bool winding = false;
    sys::EventFd wound_fd{"eventfd for the end of a wind-down"};  // every fallback answered
    bool wound_set = false;

    rtu::Instant next_status{};
    bool last_up = false;
    bool status_due = true;
    std::uint64_t dropped_seen = 0;
    std::uint64_t lost_seen = 0;

    void run() {
        sys::EventLoop events;
        sys::Timer timer;
        auto& handover = loop.handover();
        const std::array added = {events.add(intake.ready_fd(),
                                             [&] {
                                                 const Woken woken(*this);
                                                 intake.take(sys::now());
                                                 republish();
                                                 keep_record();
                                             }),
                                  events.add(handover.ready_fd(),
                                             [&] {
                                                 const Woken woken(*this);
                                                 handover.acknowledge();
                                                 drain();
                                                 republish();
                                                 keep_record();
                                             }),
                                  events.add(timer.fd(),
                                             [&] {
                                                 const Woken woken(*this);
                                                 timer.acknowledge();
                                                 tick(timer);
                                             }),
                                  events.add(wind_fd.fd(),
                                             [&] {
                                                 const Woken woken(*this);
                                                 wind_fd.drain();
                                                 wind_down();
                                             }),
                                  events.add(stop_fd.fd(), [&] { events.stop(); }),
                                  wakers ? events.add(wakers->fd(), [&] { wakers->accept_waiting(); })
                                         : std::expected<void, sys::SysError>{}};
        for (const auto& a : added) {
            if (!a) {
                log::error(
                    fmt::format("bus {}: ipc event loop: {}: clients are not served", bus.name, a.error().message()));
                return;
            }
        }
        intake.take(sys::now());  // what came before the listener was attached
        tick(timer);
        if (auto ran = events.run(); !ran) {
            log::error(fmt::format("bus {}: ipc event loop: {}", bus.name, ran.error().message()));
        }
    }

    // Wakes the applications on their own event loops once a callback of the ipc thread has
    // published or answered anything (after it has: a wake-up announces what is there already).
    struct Woken {
        explicit Woken(Impl& i) : impl(i), before(i.activity()) {}
        ~Woken() {
            if (impl.wakers && impl.activity() != before) {
                impl.wakers->wake();
            }
        }
        Woken(const Woken&) = delete;
        Woken& operator=(const Woken&) = delete;
        Woken(Woken&&) = delete;
        Woken& operator=(Woken&&) = delete;
        Impl& impl;
        std::uint64_t before;
    };
    [[nodiscard]] std::uint64_t activity() const noexcept { return publisher.publications() + intake.answers(); }

    // Results and snapshots the bus thread handed over.
    void drain() {
        auto& handover = loop.handover();
        master::Finished f;
        while (handover.results.try_pop(f)) {
            intake.answer(f);
        }
        master::DriveSnapshot s;
        while (handover.snapshots.try_pop(s)) {
            if (const auto drive = publisher.drive_index(s.name)) {
                status_due |= publisher.snapshot(*drive, s, leases.status(*drive));
            }
        }
        if (status_due) {
            publisher.status(loop.status(), {intake.served(), intake.queue_full(), leases.expiries()});
            status_due = false;
        }
        report_losses();
    }

    void report_losses() {
        auto& handover = loop.handover();
        if (const auto dropped = handover.snapshots_dropped.load(); dropped != dropped_seen) {
            log::warning(fmt::format("bus {}: {} snapshots dropped: the ipc thread fell behind the bus", bus.name,
                                     dropped - dropped_seen));
            dropped_seen = dropped;
        }
        if (const auto lost = handover.results_lost.load(); lost != lost_seen) {
            log::error(
                fmt::format("bus {}: {} results had no room in the ring (a defect: it is sized to the "
                            "queue limit)",
                            bus.name, lost - lost_seen));
            lost_seen = lost;
        }
    }

    // The lease record follows every change of who holds what (not the renewals: the same
    // record is not written again).
    void keep_record() {
        record.keep(leases.record());
        if (winding && !wound_set && !leases.fallbacks_pending()) {
            wound_set = true;
            wound_fd.signal();
        }
    }

    // Submitted to the bus (a fallback the bus cannot take is answered failed at once).
    void apply(const FallbackAction& f) {
        write_note(f.note);
        if (f.write && !intake.submit_own(f.drive, *f.write)) {
            write_note(leases.fallback_done(f.drive, master::Outcome::BusDown, true).note);
        }
        publisher.lease(f.drive, leases.status(f.drive));
    }

    // drivebusd stops: no request is taken any more, every lease held ends with its fallback,
    // and the bus sends those alone.
    void wind_down() {
        if (winding) {
            return;
        }
        winding = true;
        intake.close();
        for (const auto& f : leases.surrender(sys::now())) {
            apply(f);
        }
        loop.wind_down();
        keep_record();
    }

    // drivebusd starts: the leases its predecessor held when it ended get their fallbacks,
    // submitted before the bus thread runs, so that they are the first requests on the line.
    void recover() {
        const auto recorded = record.read();
        if (!recorded) {
            return;
        }
        auto recovery = leases.recover(*recorded, sys::now());
        for (const auto& note : recovery.notes) {
            write_note(note);
        }
        for (const auto& f : recovery.fallbacks) {
            apply(f);
        }
    }

    void republish() {
        for (const auto drive : intake.take_republish()) {
            publisher.lease(drive, leases.status(drive));
        }
    }

    void tick(sys::Timer& timer) {
        const auto now = sys::now();
        for (const auto& f : leases.expire(now)) {
            apply(f);
        }
        republish();
        keep_record();
        // Once a second, and at once when the line goes up or down.
        const bool up = loop.up();
        if (now >= next_status || up != last_up || status_due) {
            publisher.status(loop.status(), {intake.served(), intake.queue_full(), leases.expiries()});
            next_status = now + kStatusInterval;
            status_due = false;
        }
        last_up = up;
        auto until = std::min(next_status, now + kStatusCheck);
        if (const auto deadline = leases.next_deadline()) {
            until = std::min(until, *deadline);
        }
        if (auto armed = timer.arm(until); !armed) {
            log::error(fmt::format("bus {}: ipc timer: {}", bus.name, armed.error().message()));
        }
    }
};

BusService::BusService(const config::BusConfig& bus, const Layout& layout, bus::BusLoop& loop, const Carried& carried)
    : impl_(std::make_unique<Impl>(bus, layout, loop, carried.server, carried.wakers)) {
    for (const auto& note : impl_->leases.adopt(carried.leases)) {
        write_note(note);
    }
    impl_->publisher.continue_sequences(carried.sequences);
    // A bus restarted by a reload carries its leases; any other start finds out what the last
    // drivebusd held.
    if (!carried.server) {
        impl_->recover();
    }
    impl_->keep_record();
    // The adopted and recovered leases are published with each drive's first snapshot.
}

int BusService::wind_down() {
    impl_->wind_fd.signal();
    return impl_->wound_fd.fd();
}

Carried BusService::retire() {
    stop();
    impl_->drain();
    impl_->intake.abandon();
    impl_->keep_record();
    return {impl_->leases.carry(), impl_->publisher.sequences(), impl_->intake.release(), impl_->wakers};
}

BusService::~BusService() {
    stop();
}

std::size_t BusService::drives_online() const {
    return impl_->publisher.drives_online();
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

void BusService::start(const std::function<void()>& on_thread) {
    impl_->thread = std::thread([this, on_thread] {
        (void)::pthread_setname_np(::pthread_self(), ("ipc " + impl_->bus.name).substr(0, 15).c_str());
        const log::ThreadFields fields({.bus = impl_->bus.name});  // BUS= on every line of this thread
        if (on_thread) {
            on_thread();
        }
        impl_->run();
    });
}

void BusService::stop() {
    if (impl_->thread.joinable()) {
        impl_->stop_fd.signal();
        impl_->thread.join();
    }
}

}  // namespace drivebus::ipc
