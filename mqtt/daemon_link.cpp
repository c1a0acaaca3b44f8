// SPDX-License-Identifier: Apache-2.0
#include "daemon_link.hpp"

#include <array>
#include <utility>

namespace drivebus::mqtt {
namespace {

class DriveLink final : public DrivePort {
public:
    DriveLink(Drive drive, BusPort::SnapshotSink sink)
        : drive_(std::move(drive)), subscription_(drive_.on_snapshot(std::move(sink))) {}

    [[nodiscard]] const Profile* profile() const override { return drive_.profile(); }
    void write(std::uint16_t address, std::uint16_t raw, WriteOptions options, Done done) override {
        const std::array<std::uint16_t, 1> word{raw};
        drive_.async_write(address, word, adapt(std::move(done)), options);
    }
    void keep_alive(Done done) override { drive_.async_keep_alive(adapt(std::move(done))); }
    void release_control(Done done) override { drive_.async_release_control(adapt(std::move(done))); }

private:
    static Drive::Done adapt(Done done) {
        return [done = std::move(done)](std::expected<void, Error> result) { done(result); };
    }

    Drive drive_;
    Subscription subscription_;
};

class BusLink final : public BusPort {
public:
    explicit BusLink(Bus bus) : bus_(std::move(bus)) {}

    [[nodiscard]] int descriptor() const override { return bus_.descriptor(); }
    void dispatch() override { (void)bus_.dispatch(); }
    [[nodiscard]] std::optional<shm::BusStatus> status() const override {
        auto s = bus_.status();
        if (!s) {
            return std::nullopt;
        }
        return *s;
    }
    [[nodiscard]] bool daemon_alive() const override { return bus_.daemon_alive(); }
    std::expected<std::unique_ptr<DrivePort>, std::string> drive(std::string_view name, SnapshotSink sink) override {
        auto drive = bus_.drive(name);
        if (!drive) {
            return std::unexpected(drive.error().message);
        }
        return std::make_unique<DriveLink>(std::move(*drive), std::move(sink));
    }

private:
    Bus bus_;
};

}  // namespace

std::expected<std::unique_ptr<BusPort>, std::string> DaemonLink::connect(std::string_view name) {
    ConnectOptions options;
    options.application = "drivebus-mqtt";
    options.delivery = Delivery::Dispatch;  // on the bridge's loop: no thread of the library's
    auto bus = Bus::connect(name, options);
    if (!bus) {
        return std::unexpected(bus.error().message);
    }
    return std::make_unique<BusLink>(std::move(*bus));
}

}  // namespace drivebus::mqtt
