// SPDX-License-Identifier: Apache-2.0
// drivebus::Bus, the handle applications hold: connecting (which bus, the runtime, the daemon
// there), the bus's status, requests and broadcasts; the work is Bus::Impl's (bus.cpp).
#include <algorithm>

#include "bus_impl.hpp"

namespace drivebus {

Bus::Bus(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}
Bus::~Bus() = default;
Bus::Bus(Bus&&) noexcept = default;
Bus& Bus::operator=(Bus&&) noexcept = default;

std::expected<Bus, Error> Bus::connect(std::string_view bus, ConnectOptions options) {
    if (auto ok = ensure_runtime(options.application); !ok) {
        return std::unexpected(ok.error());
    }
    std::string name(bus);
    if (name.empty()) {
        const auto buses = discover_buses(options.connect_timeout);
        if (buses.empty()) {
            return std::unexpected(make_error(ErrorKind::NoSuchBus, "drivebusd announces no bus"));
        }
        if (buses.size() > 1) {
            std::string list;
            for (const auto& b : buses) {
                list += (list.empty() ? "" : ", ") + b;
            }
            return std::unexpected(
                make_error(ErrorKind::InvalidArgument, "drivebusd runs several buses (" + list + "): name one"));
        }
        name = buses.front();
    }
    auto impl = std::make_shared<Impl>(name, std::move(options));
    if (auto ok = impl->open(); !ok) {
        return std::unexpected(ok.error());
    }
    return Bus(std::move(impl));
}

std::expected<std::vector<std::string>, Error> Bus::list(ConnectOptions options) {
    if (auto ok = ensure_runtime(options.application); !ok) {
        return std::unexpected(ok.error());
    }
    return discover_buses(options.connect_timeout);
}

const std::string& Bus::name() const noexcept {
    return impl_->name;
}

std::expected<shm::BusStatus, Error> Bus::status(Milliseconds wait) const {
    std::unique_lock lock(impl_->mutex);
    impl_->wait(lock, deadline_after(wait), [&] { return impl_->status.has_value(); });
    if (!impl_->status) {
        return std::unexpected(make_error(ErrorKind::DaemonGone, "no status from bus '" + impl_->name + "'"));
    }
    return *impl_->status;
}

bool Bus::daemon_alive() const {
    return impl_->alive();
}

bool Bus::can_request() const {
    return impl_->may_request;
}

std::uint64_t Bus::client_id() const noexcept {
    return impl_->client_id;
}

Subscription Bus::on_status(std::function<void(const shm::BusStatus&)> callback) const {
    std::uint64_t key = 0;
    {
        std::lock_guard lock(impl_->mutex);
        key = impl_->next_callback++;
        impl_->status_callbacks.emplace(key, std::move(callback));
    }
    return Subscription([impl = impl_, key] {
        {
            std::lock_guard lock(impl->mutex);
            impl->status_callbacks.erase(key);
        }
        quiesce(*impl->gate);
    });
}

std::expected<shm::Response, Error> Bus::request(shm::Request request) const {
    return impl_->call(request);
}

void Bus::async_request(shm::Request request, ResponseDone done) const {
    if (impl_->options.delivery != Delivery::Dispatch) {
        done(std::unexpected(make_error(ErrorKind::InvalidArgument,
                                        "asynchronous requests need a Bus connected with Delivery::Dispatch")));
        return;
    }
    impl_->submit(request, std::move(done));
}

int Bus::descriptor() const noexcept {
    return impl_->options.delivery == Delivery::Dispatch ? impl_->epoll.get() : -1;
}

std::size_t Bus::dispatch() const {
    return impl_->options.delivery == Delivery::Dispatch ? impl_->dispatch() : 0;
}

std::expected<Drive, Error> Bus::drive(std::string_view which) const {
    std::lock_guard lock(impl_->mutex);
    for (const auto& d : impl_->drives) {
        if (d->name == which || std::to_string(d->address) == which) {
            return Drive(impl_, d->name, d->address, d->profile);
        }
    }
    std::string names;
    for (const auto& d : impl_->drives) {
        names += (names.empty() ? "" : ", ") + d->name + " (" + std::to_string(d->address) + ")";
    }
    return std::unexpected(make_error(ErrorKind::InvalidArgument, "bus '" + impl_->name + "' has no drive '" +
                                                                      std::string(which) + "'; it has " + names));
}

std::expected<void, Error> Bus::broadcast(std::uint16_t address, std::span<const std::uint16_t> values) const {
    if (values.empty() || values.size() > shm::kMaxWriteWords) {
        return std::unexpected(make_error(ErrorKind::InvalidArgument, "a broadcast carries 1-123 words"));
    }
    shm::Request r;
    r.kind = shm::RequestKind::Broadcast;
    r.start = address;
    r.count = static_cast<std::uint16_t>(values.size());
    std::ranges::copy(values, r.values.begin());
    auto response = impl_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    return check_response("bus '" + impl_->name + "' (broadcast)", *response);
}

}  // namespace drivebus
