// SPDX-License-Identifier: Apache-2.0
#include "ipc/intake.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <unordered_map>

#include "iceoryx_posh/popo/listener.hpp"
#include "iceoryx_posh/popo/untyped_server.hpp"
#include "ipc/intake_core.hpp"
#include "ipc/note_log.hpp"
#include "ipc/service.hpp"
#include "sys/event_fd.hpp"

namespace drivebus::ipc {

using iox::popo::RequestHeader;

namespace {

// The unique id of the client queue a request's answer goes to: iceoryx keeps it to its server
// port (a protected member), named here through a class of its own.
struct ClientQueue : RequestHeader {
    static std::uint64_t of(const RequestHeader& header) {
        constexpr auto queue = &ClientQueue::m_uniqueClientQueueId;
        return static_cast<std::uint64_t>(header.*queue);
    }
};

}  // namespace

struct Intake::Server {
    explicit Server(const std::string& bus) : server(service(bus, shm::kRequestEvent), iox::popo::ServerOptions{}) {}
    iox::popo::UntypedServer server;
};

struct Intake::Impl {
    Impl(const config::BusConfig& b, bus::BusLoop& l, LeasePolicy& leases, std::shared_ptr<Intake::Server> adopted,
         std::function<void()> journal)
        : loop(l),
          ready("eventfd for bus " + b.name + "'s requests"),
          port(adopted ? std::move(adopted) : std::make_shared<Intake::Server>(b.name)),
          server(port->server),
          core(
              b, leases, [this](const master::ClientRequest& r) { return loop.submit(r).has_value(); },
              std::move(journal), [this](RouteId route) { return ClientQueue::of(routes.at(route)); },
              [](const Note& note) { write_note(note); }) {
        if (listener
                .attachEvent(server, iox::popo::ServerEvent::REQUEST_RECEIVED,
                             iox::popo::createNotificationCallback(on_request, *this))
                .has_error()) {
            throw std::runtime_error("bus " + b.name + ": iceoryx refused a listener for its requests");
        }
    }
    ~Impl() { detach(); }
    void detach() {
        if (attached) {
            listener.detachEvent(server, iox::popo::ServerEvent::REQUEST_RECEIVED);
            attached = false;
        }
    }
    Impl(const Impl&) = delete;
    Impl& operator=(const Impl&) = delete;
    Impl(Impl&&) = delete;
    Impl& operator=(Impl&&) = delete;

    // On iceoryx's listener thread: only wakes the ipc thread.
    static void on_request(iox::popo::UntypedServer* /*server*/, Impl* self) { self->ready.signal(); }

    // A request's header, kept under an id of its own until the request's one answer is sent.
    RouteId keep(RequestHeader&& header) {
        const RouteId id = next_route++;
        routes.emplace(id, std::move(header));
        return id;
    }
    // Answers through `route`, which is done with.
    void send(RouteId route, const shm::Response& response) {
        const auto it = routes.find(route);
        if (it == routes.end()) {
            return;
        }
        auto loaned = server.loan(&it->second, sizeof(shm::Response), alignof(shm::Response));
        if (!loaned.has_error()) {  // else the client has gone: nothing to answer
            std::memcpy(loaned.value(), &response, sizeof response);
            (void)server.send(loaned.value());
            ++answers;
        }
        routes.erase(it);
    }
    std::uint64_t answers = 0;

    bus::BusLoop& loop;
    sys::EventFd ready;
    std::shared_ptr<Intake::Server> port;
    iox::popo::UntypedServer& server;
    std::unordered_map<RouteId, RequestHeader> routes;  // of the requests not yet answered
    RouteId next_route = 0;
    IntakeCore core;
    iox::popo::Listener listener;
    bool attached = true;
};

Intake::Intake(const config::BusConfig& bus, bus::BusLoop& loop, LeasePolicy& leases, std::shared_ptr<Server> adopted,
               std::function<void()> journal)
    : impl_(std::make_unique<Impl>(bus, loop, leases, std::move(adopted), std::move(journal))) {}

std::shared_ptr<Intake::Server> Intake::release() {
    impl_->detach();
    return impl_->port;
}

Intake::~Intake() = default;

int Intake::ready_fd() const noexcept {
    return impl_->ready.fd();
}

void Intake::take(rtu::Instant now) {
    impl_->ready.drain();
    for (;;) {
        auto taken = impl_->server.take();
        if (taken.has_error()) {
            return;
        }
        const void* payload = taken.value();
        const auto* header = RequestHeader::fromPayload(payload);
        const auto size = header->getChunkHeader()->userPayloadSize();
        shm::Request request{};
        std::memcpy(&request, payload, std::min<std::size_t>(size, sizeof request));
        if (size != sizeof request) {
            request.size = static_cast<std::uint32_t>(size);
        }
        // The header only routes the response: keep a copy, give the chunk back now.
        const RouteId route = impl_->keep(std::move(*const_cast<RequestHeader*>(header)));
        impl_->server.releaseRequest(payload);
        if (const auto now_answer = impl_->core.accept(request, route, impl_->loop.up(), now)) {
            impl_->send(route, *now_answer);
        }
    }
}

void Intake::answer(const master::Finished& f) {
    auto a = impl_->core.finish(f);
    if (a && a->entry.route) {
        impl_->send(*a->entry.route, a->response);
    }
    if (a && a->entry.withdrawal) {
        impl_->send(*a->entry.withdrawal, a->response);
    }
}

void Intake::abandon() {
    for (auto& a : impl_->core.abandon()) {
        if (a.entry.route) {
            impl_->send(*a.entry.route, a.response);
        }
        if (a.entry.withdrawal) {
            impl_->send(*a.entry.withdrawal, a.response);
        }
    }
}

void Intake::close() noexcept {
    impl_->core.close();
}

bool Intake::submit_own(std::size_t drive, const rtu::RequestAdu& write) {
    return impl_->core.submit_own(drive, write);
}

std::vector<std::size_t> Intake::take_republish() {
    return impl_->core.take_republish();
}

std::uint64_t Intake::answers() const noexcept {
    return impl_->answers;
}

std::uint64_t Intake::served() const noexcept {
    return impl_->core.served();
}

std::uint64_t Intake::queue_full() const noexcept {
    return impl_->core.queue_full();
}

std::size_t Intake::in_flight() const noexcept {
    return impl_->core.book().size();
}

}  // namespace drivebus::ipc
