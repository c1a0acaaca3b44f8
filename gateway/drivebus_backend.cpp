// SPDX-License-Identifier: Apache-2.0
#include "drivebus_backend.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

namespace drivebus::gateway {
namespace {

constexpr std::uint8_t kMaxUnit = 247;

Error error(ErrorKind kind, std::string message) {
    Error e;
    e.kind = kind;
    e.message = std::move(message);
    return e;
}

}  // namespace

std::expected<Bus*, Error> DrivebusBackend::bus(const std::string& name, const ConnectOptions& options) {
    if (const auto it = buses_.find(name); it != buses_.end()) {
        return it->second.get();
    }
    auto bus = Bus::connect(name, options);
    if (!bus) {
        return std::unexpected(bus.error());
    }
    if (!bus->can_request()) {
        return std::unexpected(error(ErrorKind::NotPermitted,
                                     fmt::format("bus {}: this user may not send requests (not in the bus's control "
                                                 "group): the gateway needs it for writes and unpolled reads",
                                                 name)));
    }
    auto* raw = buses_.emplace(name, std::make_unique<Bus>(std::move(*bus))).first->second.get();
    return raw;
}

std::expected<std::unique_ptr<DrivebusBackend>, Error> DrivebusBackend::connect(const Config& config) {
    std::unique_ptr<DrivebusBackend> b(new DrivebusBackend());
    ConnectOptions options;
    options.application = "drivebus-gateway";
    options.request_timeout = config.request_timeout;
    options.delivery = Delivery::Dispatch;  // on the server's loop: no thread of the library's
    std::string default_bus = config.bus;
    const bool every_unit_names_its_bus =
        !config.units.empty() &&
        std::all_of(config.units.begin(), config.units.end(), [](const UnitRoute& u) { return !u.bus.empty(); });
    if (default_bus.empty() && !every_unit_names_its_bus) {
        auto buses = Bus::list(options);
        if (!buses) {
            return std::unexpected(buses.error());
        }
        if (buses->size() != 1) {
            return std::unexpected(
                error(ErrorKind::InvalidArgument, fmt::format("drivebusd announces {} buses ({}): say which one in "
                                                              "gateway.bus, or give each [[unit]] its bus",
                                                              buses->size(), fmt::join(*buses, ", "))));
        }
        default_bus = buses->front();
    }
    if (config.units.empty()) {
        auto bus = b->bus(default_bus, options);
        if (!bus) {
            return std::unexpected(bus.error());
        }
        const auto status = (*bus)->status(options.connect_timeout);
        if (!status) {
            return std::unexpected(status.error());
        }
        for (std::size_t i = 0; i < status->drive_count && i < status->drives.size(); ++i) {
            const auto& entry = status->drives[i];
            if (entry.address == 0 || entry.address > kMaxUnit) {
                continue;
            }
            auto drive = (*bus)->drive(shm::view(entry.name));
            if (!drive) {
                return std::unexpected(drive.error());
            }
            b->units_[entry.address] =
                Unit{Route{default_bus, std::string(shm::view(entry.name))}, *bus, std::move(*drive)};
        }
        return b;
    }
    for (const auto& u : config.units) {
        const std::string name = u.bus.empty() ? default_bus : u.bus;
        auto bus = b->bus(name, options);
        if (!bus) {
            return std::unexpected(bus.error());
        }
        auto drive = (*bus)->drive(u.drive);
        if (!drive) {
            return std::unexpected(
                error(drive.error().kind, fmt::format("unit {}: {}", u.unit, drive.error().message)));
        }
        const std::string drive_name = drive->name();
        b->units_[u.unit] = Unit{Route{name, drive_name}, *bus, std::move(*drive)};
    }
    return b;
}

const Route* DrivebusBackend::route(std::uint8_t unit) const {
    const auto& u = units_[unit];
    return u ? &u->route : nullptr;
}

std::optional<shm::DriveSnapshot> DrivebusBackend::snapshot(std::uint8_t unit) const {
    const auto& u = units_[unit];
    if (!u) {
        return std::nullopt;
    }
    auto snap = u->drive.wait_snapshot(Milliseconds(0));
    if (!snap) {
        return std::nullopt;
    }
    return *snap;
}

void DrivebusBackend::submit(std::uint8_t unit, const shm::Request& request, Done done) {
    const auto& u = units_[unit];
    if (!u) {  // the server routes only units that route() knows
        done(std::unexpected(error(ErrorKind::NoSuchBus, fmt::format("no drive at unit {}", unit))));
        return;
    }
    u->bus->async_request(request, std::move(done));
}

std::vector<int> DrivebusBackend::descriptors() const {
    std::vector<int> fds;
    for (const auto& [name, bus] : buses_) {
        fds.push_back(bus->descriptor());
    }
    return fds;
}

void DrivebusBackend::dispatch() {
    for (const auto& [name, bus] : buses_) {
        bus->dispatch();  // never waits: a bus with nothing new returns at once
    }
}

bool DrivebusBackend::alive() const {
    return std::all_of(buses_.begin(), buses_.end(), [](const auto& b) { return b.second->daemon_alive(); });
}

std::string DrivebusBackend::describe() const {
    std::string out;
    for (std::size_t unit = 0; unit < units_.size(); ++unit) {
        if (units_[unit]) {
            out += fmt::format("{}unit {} {}/{}", out.empty() ? "" : ", ", unit, units_[unit]->route.bus,
                               units_[unit]->route.drive);
        }
    }
    return out.empty() ? "no drive" : out;
}

}  // namespace drivebus::gateway
