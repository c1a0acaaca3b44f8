// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <charconv>
#include <cstdio>

#include "bus_impl.hpp"

namespace drivebus {
namespace {

std::optional<std::uint16_t> parse_number(std::string_view text) {
    int base = 10;
    if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
        text.remove_prefix(2);
        base = 16;
    }
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, base);
    if (ec != std::errc{} || end != text.data() + text.size() || value > 0xFFFF || text.empty()) {
        return std::nullopt;
    }
    return static_cast<std::uint16_t>(value);
}

}  // namespace

Drive::Drive(std::shared_ptr<Bus::Impl> bus, std::string name, std::uint8_t address,
             std::shared_ptr<const Profile> profile)
    : bus_(std::move(bus)), name_(std::move(name)), address_(address), profile_(std::move(profile)) {}

const std::string& Drive::name() const noexcept {
    return name_;
}

std::uint8_t Drive::address() const noexcept {
    return address_;
}

const Profile* Drive::profile() const noexcept {
    return profile_.get();
}

const RegisterInfo* Drive::info(std::uint16_t address) const noexcept {
    return profile_ ? profile_->find(address) : nullptr;
}

std::expected<std::uint16_t, Error> Drive::resolve(std::string_view reg) const {
    if (profile_) {
        if (const auto* r = profile_->find(reg); r != nullptr) {
            if (!r->address) {
                return std::unexpected(
                    make_error(ErrorKind::InvalidArgument, r->name + " has no Modbus address (keypad only)"));
            }
            return *r->address;
        }
    }
    if (const auto n = parse_number(reg)) {
        return *n;
    }
    return std::unexpected(
        make_error(ErrorKind::InvalidArgument, "'" + std::string(reg) + "' is neither a register of profile " +
                                                   (profile_ ? profile_->type : std::string("(none)")) +
                                                   " nor a number (decimal or 0x hex)"));
}

std::expected<shm::DriveSnapshot, Error> Drive::wait_snapshot(Milliseconds wait, std::uint64_t after) const {
    auto* feed = bus_->feed(name_);
    std::unique_lock lock(bus_->mutex);
    bus_->wait(lock, deadline_after(wait), [&] { return feed->last && feed->last->sequence > after; });
    if (feed->last && feed->last->sequence > after) {
        return *feed->last;
    }
    const bool alive = bus_->status.has_value() && Clock::now() - bus_->status_time < bus_->options.daemon_silence;
    if (!alive) {
        return std::unexpected(
            make_error(ErrorKind::DaemonGone, "drivebusd has gone silent: no snapshot of drive '" + name_ + "'"));
    }
    return std::unexpected(make_error(
        ErrorKind::NoReply, "no new snapshot of drive '" + name_ + "' within " + std::to_string(wait.count()) + " ms"));
}

Subscription Drive::on_snapshot(std::function<void(const shm::DriveSnapshot&)> callback) const {
    auto* feed = bus_->feed(name_);
    std::uint64_t key = 0;
    {
        std::lock_guard lock(bus_->mutex);
        key = bus_->next_callback++;
        feed->callbacks.emplace(key, std::move(callback));
    }
    return Subscription([bus = bus_, feed, key] {
        {
            std::lock_guard lock(bus->mutex);
            feed->callbacks.erase(key);
        }
        quiesce(*bus->gate);
    });
}

std::expected<std::vector<std::uint16_t>, Error> Drive::read(std::uint16_t address, std::uint16_t count) const {
    shm::Request r;
    r.kind = shm::RequestKind::Read;
    shm::assign(r.drive, name_);
    r.start = address;
    r.count = count;
    auto response = bus_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    if (auto ok = check_response("drive '" + name_ + "'", *response, profile_.get()); !ok) {
        return std::unexpected(ok.error());
    }
    return std::vector<std::uint16_t>(response->values.begin(), response->values.begin() + response->count);
}

std::expected<std::vector<std::uint16_t>, Error> Drive::read(std::string_view reg, std::uint16_t count) const {
    auto address = resolve(reg);
    if (!address) {
        return std::unexpected(address.error());
    }
    return read(*address, count);
}

std::expected<void, Error> Drive::write(std::uint16_t address, std::span<const std::uint16_t> values,
                                        WriteOptions options) const {
    if (values.empty() || values.size() > shm::kMaxWriteWords) {
        return std::unexpected(make_error(ErrorKind::InvalidArgument, "a write carries 1-123 words"));
    }
    shm::Request r;
    r.kind = shm::RequestKind::Write;
    r.flags = options.take_over ? shm::kFlagTakeOver : 0;
    shm::assign(r.drive, name_);
    r.start = address;
    r.count = static_cast<std::uint16_t>(values.size());
    std::ranges::copy(values, r.values.begin());
    if (options.deadline) {
        r.deadline_ns = monotonic_ns(Clock::now() + *options.deadline);
    }
    auto response = bus_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    return check_response("drive '" + name_ + "'", *response, profile_.get());
}

std::expected<void, Error> Drive::write(std::string_view reg, std::span<const std::uint16_t> values,
                                        WriteOptions options) const {
    auto address = resolve(reg);
    if (!address) {
        return std::unexpected(address.error());
    }
    return write(*address, values, options);
}

std::expected<Identity, Error> Drive::identify() const {
    shm::Request r;
    r.kind = shm::RequestKind::Identify;
    shm::assign(r.drive, name_);
    auto response = bus_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    if (auto ok = check_response("drive '" + name_ + "'", *response, profile_.get()); !ok) {
        return std::unexpected(ok.error());
    }
    return Identity{std::string(shm::view(response->identity[0])), std::string(shm::view(response->identity[1])),
                    std::string(shm::view(response->identity[2]))};
}

std::expected<void, Error> Drive::keep_alive() const {
    shm::Request r;
    r.kind = shm::RequestKind::LeaseRenew;
    shm::assign(r.drive, name_);
    auto response = bus_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    return check_response("drive '" + name_ + "'", *response, profile_.get());
}

std::expected<void, Error> Drive::release_control() const {
    shm::Request r;
    r.kind = shm::RequestKind::LeaseRelease;
    shm::assign(r.drive, name_);
    auto response = bus_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    return check_response("drive '" + name_ + "'", *response, profile_.get());
}

namespace {

// A request of this drive's, by callback: `then` turns its response into what `done` takes.
template <typename Done, typename Then>
void submit_async(Bus::Impl& bus, const shm::Request& r, Done done, Then then) {
    if (bus.options.delivery != Delivery::Dispatch) {
        done(std::unexpected(make_error(ErrorKind::InvalidArgument,
                                        "asynchronous requests need a Bus connected with Delivery::Dispatch")));
        return;
    }
    bus.submit(r, [done = std::move(done), then = std::move(then)](std::expected<shm::Response, Error> response) {
        if (!response) {
            done(std::unexpected(response.error()));
            return;
        }
        done(then(*response));
    });
}

shm::Request drive_request(shm::RequestKind kind, const std::string& drive) {
    shm::Request r;
    r.kind = kind;
    shm::assign(r.drive, drive);
    return r;
}

}  // namespace

void Drive::async_read(std::uint16_t address, std::uint16_t count, ReadDone done) const {
    auto r = drive_request(shm::RequestKind::Read, name_);
    r.start = address;
    r.count = count;
    submit_async(
        *bus_, r, std::move(done),
        [name = name_,
         profile = profile_](const shm::Response& response) -> std::expected<std::vector<std::uint16_t>, Error> {
            if (auto ok = check_response("drive '" + name + "'", response, profile.get()); !ok) {
                return std::unexpected(ok.error());
            }
            return std::vector<std::uint16_t>(response.values.begin(), response.values.begin() + response.count);
        });
}

void Drive::async_write(std::uint16_t address, std::span<const std::uint16_t> values, Done done,
                        WriteOptions options) const {
    if (values.empty() || values.size() > shm::kMaxWriteWords) {
        done(std::unexpected(make_error(ErrorKind::InvalidArgument, "a write carries 1-123 words")));
        return;
    }
    auto r = drive_request(shm::RequestKind::Write, name_);
    r.flags = options.take_over ? shm::kFlagTakeOver : 0;
    r.start = address;
    r.count = static_cast<std::uint16_t>(values.size());
    std::ranges::copy(values, r.values.begin());
    if (options.deadline) {
        r.deadline_ns = monotonic_ns(Clock::now() + *options.deadline);
    }
    submit_async(*bus_, r, std::move(done), [name = name_, profile = profile_](const shm::Response& response) {
        return check_response("drive '" + name + "'", response, profile.get());
    });
}

void Drive::async_keep_alive(Done done) const {
    submit_async(*bus_, drive_request(shm::RequestKind::LeaseRenew, name_), std::move(done),
                 [name = name_, profile = profile_](const shm::Response& response) {
                     return check_response("drive '" + name + "'", response, profile.get());
                 });
}

void Drive::async_release_control(Done done) const {
    submit_async(*bus_, drive_request(shm::RequestKind::LeaseRelease, name_), std::move(done),
                 [name = name_, profile = profile_](const shm::Response& response) {
                     return check_response("drive '" + name + "'", response, profile.get());
                 });
}

bool Drive::holds_control() const {
    std::lock_guard lock(bus_->mutex);
    return bus_->lease_tokens.contains(name_);
}

}  // namespace drivebus
