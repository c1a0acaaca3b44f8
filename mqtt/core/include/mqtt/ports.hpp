// SPDX-License-Identifier: Apache-2.0
// What the Relay (mqtt/relay.hpp) needs of the world, as interfaces: the broker it publishes
// to, and drivebusd with its buses and drives. drivebus-mqtt implements them on libmosquitto
// (mqtt/broker_link.hpp) and libdrivebus (mqtt/daemon_link.hpp); tests implement them in memory
// (tests/mqtt/relay_test.cpp), which is how a broker that stalls or a bus whose status never
// comes is reached on a virtual clock.
//
// Every call is made on the bridge's loop thread, and every callback a port is given runs on
// it too, from the port's dispatch().
#pragma once

#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "drivebus/client.hpp"

namespace drivebus::mqtt {

// An interface: no copies, deleted through the base.
class Port {
public:
    Port() = default;
    virtual ~Port() = default;
    Port(const Port&) = delete;
    Port& operator=(const Port&) = delete;
    Port(Port&&) = delete;
    Port& operator=(Port&&) = delete;
};

class Broker : public Port {
public:
    [[nodiscard]] virtual bool connected() const = 0;
    // False when the broker did not take it (not connected, too many unacknowledged): nothing
    // is queued, the caller publishes again later if it still matters.
    virtual bool publish(const std::string& topic, std::string_view payload, int qos, bool retain) = 0;
};

// One drive of a bus, as drivebusd serves it. The requests complete by `done`, exactly once,
// in a later dispatch() of its bus (not at all if the bus is dropped first).
class DrivePort : public Port {
public:
    using Done = std::function<void(const std::expected<void, Error>&)>;
    [[nodiscard]] virtual const Profile* profile() const = 0;
    virtual void write(std::uint16_t address, std::uint16_t raw, WriteOptions options, Done done) = 0;
    virtual void keep_alive(Done done) = 0;
    virtual void release_control(Done done) = 0;
};

// A bus drivebusd announces, connected.
class BusPort : public Port {
public:
    using SnapshotSink = std::function<void(const shm::DriveSnapshot&)>;
    // The descriptor the loop watches; readable: call dispatch().
    [[nodiscard]] virtual int descriptor() const = 0;
    // Runs what has arrived: statuses, snapshots, requests' completions. Never waits.
    virtual void dispatch() = 0;
    // The latest bus status; nothing before the first has come.
    [[nodiscard]] virtual std::optional<shm::BusStatus> status() const = 0;
    // False once drivebusd has been silent too long.
    [[nodiscard]] virtual bool daemon_alive() const = 0;
    // The drive `name`, its snapshots handed to `sink` (in dispatch()) for as long as the port
    // lives; an error's message when it cannot be had.
    virtual std::expected<std::unique_ptr<DrivePort>, std::string> drive(std::string_view name, SnapshotSink sink) = 0;
};

class Daemon : public Port {
public:
    // Connects to the bus `name`: fails at once (its message) when drivebusd does not run or does
    // not announce it. Never waits for the bus's first status.
    virtual std::expected<std::unique_ptr<BusPort>, std::string> connect(std::string_view name) = 0;
};

}  // namespace drivebus::mqtt
