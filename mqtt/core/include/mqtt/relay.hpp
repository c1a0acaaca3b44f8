// SPDX-License-Identifier: Apache-2.0
// The bridge's loop, pure: it reaches each configured bus through drivebusd (with back-off),
// turns its drives' snapshots into retained state messages (on change beyond the deadband, and
// at least every period: cadence.hpp) and its status into a retained status message, and hands
// commands to the Commander (commander.hpp), whose steps go to the drives and whose results are
// published. The broker and drivebusd are ports (ports.hpp); time is an argument; what is worth
// a log line leaves as a RelayNote. drivebus-mqtt's Bridge (mqtt/bridge.cpp) runs it on poll()
// with libmosquitto and libdrivebus; tests run it on a virtual clock (tests/mqtt/relay_test.cpp).
//
// A bus is reached in two steps that never wait: connect (drivebusd runs and announces it),
// then its first status (which names its drives), due within kFirstStatusWait. A bus not
// reached is published as unreachable with the reason, and tried again from 1 s, doubling up to
// 30 s; the first failure in a row is a warning, the rest are silent.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mqtt/backoff.hpp"
#include "mqtt/cadence.hpp"
#include "mqtt/commander.hpp"
#include "mqtt/config.hpp"
#include "mqtt/ports.hpp"
#include "mqtt/topics.hpp"

namespace drivebus::mqtt {

inline constexpr auto kBusRetryShortest = std::chrono::seconds(1);
inline constexpr auto kBusRetryLongest = std::chrono::seconds(30);
inline constexpr auto kFirstStatusWait = std::chrono::seconds(2);
// With nothing due, the loop still turns this often.
inline constexpr auto kIdleTurn = std::chrono::seconds(1);

struct RelayNote {
    enum class Level : std::uint8_t { Debug, Notice, Warning };
    Level level = Level::Notice;
    std::string bus;
    std::string drive;
    std::string text;
};

struct RelayCounters {
    std::uint64_t states_published = 0;
    std::uint64_t bus_attempts = 0;  // connections to drivebusd tried, the successful ones too
};

class Relay {
public:
    using Time = std::chrono::steady_clock::time_point;
    using Notes = std::function<void(const RelayNote&)>;

    Relay(const Config& config, Broker& broker, Daemon& daemon, Notes notes = {});
    ~Relay();
    Relay(const Relay&) = delete;
    Relay& operator=(const Relay&) = delete;
    Relay(Relay&&) = delete;
    Relay& operator=(Relay&&) = delete;

    // The descriptors to watch: readable, call dispatch().
    [[nodiscard]] std::vector<int> descriptors() const;
    // Runs what the buses have for it (snapshots, statuses, answers to the Commander's steps).
    void dispatch(Time now);
    // A message on a set topic (commands.hpp): `received` on the wall clock, `arrived` the same
    // moment on the steady clock.
    void message(const Topics::Target& target, std::string_view payload, bool retained, WallTime received,
                 Time arrived);
    // Reaches the buses that are due and publishes what is due; `republish`: the broker has just
    // connected (again), so every retained message is published again.
    void turn(Time now, bool republish);
    // When turn() has something to do next, without any event.
    [[nodiscard]] Time next_deadline(Time now) const;

    [[nodiscard]] const RelayCounters& counters() const noexcept { return counters_; }
    [[nodiscard]] const CommanderCounters& commands() const noexcept { return commander_.counters(); }

private:
    struct DriveLink {
        DriveSettings settings;
        Cadence cadence;
        // The newest snapshot, from dispatch(); `fresh` until its state has been published or
        // found not due.
        std::optional<shm::DriveSnapshot> latest;
        bool fresh = false;
        std::unique_ptr<DrivePort> port;  // last: its sink points here, ended first
    };
    struct BusLink {
        BusSettings settings;
        Cadence cadence;
        Backoff retry{kBusRetryShortest, kBusRetryLongest};
        Time next_attempt{};
        std::string last_error;
        std::unique_ptr<BusPort> port;  // connected; its drives are there once `reached`
        Time status_due{};              // connected, not reached: the first status by then
        bool reached = false;
        std::vector<std::unique_ptr<DriveLink>> drives;
    };
    class Fleet final : public Roster {
    public:
        explicit Fleet(const Relay& relay) : relay_(relay) {}
        [[nodiscard]] bool has_bus(std::string_view bus) const override;
        [[nodiscard]] std::optional<Drive> drive(std::string_view bus, std::string_view drive) const override;

    private:
        const Relay& relay_;
    };

    void note(RelayNote::Level level, std::string bus, std::string text) const;
    void attempt(BusLink& bus, Time now);
    void reach(BusLink& bus, Time now);
    void fail(BusLink& bus, std::string error, Time now);
    void publish_bus(BusLink& bus, Time now, bool force);
    void publish_drive(BusLink& bus, DriveLink& drive, Time now, bool force);
    void carry(const CommanderEffects& effects);
    [[nodiscard]] DriveLink* find(std::string_view bus, std::string_view drive) const;

    const Config& config_;
    Broker& broker_;
    Daemon& daemon_;
    Notes notes_;
    Topics topics_;
    std::vector<std::unique_ptr<BusLink>> buses_;
    Fleet fleet_{*this};
    Commander commander_;
    RelayCounters counters_;
    Time now_{};  // the time of the dispatch() in progress: completions are stamped with it
};

}  // namespace drivebus::mqtt
