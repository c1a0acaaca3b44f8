// SPDX-License-Identifier: Apache-2.0
// The bridge's loop (mqtt/relay.hpp) on a virtual clock, with the broker and drivebusd in
// memory: a broker that stalls or comes back, a drivebusd that is not there, a bus whose first
// status never comes, drives whose answers come when the test says. What only a real broker
// and drivebusd can show stays in bridge_test.cpp.
#include <gtest/gtest.h>

#include <deque>
#include <map>

#include "mqtt/inbox.hpp"
#include "mqtt/relay.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;
using Time = Relay::Time;

const Time kT0 = Time(std::chrono::hours(100));
const WallTime kWall = WallTime(std::chrono::seconds(1'796'000'000));

Profile atv21() {
    auto p = load_profile(std::string(DRIVEBUS_TEST_PROFILE_DIR) + "/atv21.toml");
    EXPECT_TRUE(p) << p.error().message;
    return *p;
}

Config config(std::string_view extra = {}) {
    auto c = parse_config(std::string(R"(
[[bus]]
name = "line1"
period = "10s"
  [[bus.drive]]
  name = "pump"
  commands = true
  deadband = 1.0
  [[bus.drive]]
  name = "fan"
)") + std::string(extra),
                          "mqtt.toml", "board");
    EXPECT_TRUE(c) << c.error().message;
    return *c;
}

struct Published {
    std::string topic;
    Json payload;
    int qos = 0;
    bool retain = false;
};

class FakeBroker final : public Broker {
public:
    [[nodiscard]] bool connected() const override { return up; }
    bool publish(const std::string& topic, std::string_view payload, int qos, bool retain) override {
        if (!up || stalled) {
            ++refused;
            return false;
        }
        sent.push_back(Published{.topic = topic, .payload = Json::parse(payload), .qos = qos, .retain = retain});
        return true;
    }
    [[nodiscard]] std::vector<Published> on(std::string_view topic) const {
        std::vector<Published> out;
        for (const auto& p : sent) {
            if (p.topic == topic) {
                out.push_back(p);
            }
        }
        return out;
    }
    bool up = true;
    bool stalled = false;
    int refused = 0;
    std::vector<Published> sent;
};

// What the test holds of a drive request the relay made.
struct Call {
    std::string drive;
    std::string what;  // "write", "keep_alive", "release"
    std::uint16_t address = 0;
    std::uint16_t raw = 0;
    std::optional<Milliseconds> deadline;
    DrivePort::Done done;
};

// One bus as drivebusd serves it: what the test sets, and what the relay asked of it.
struct Line {
    std::optional<shm::BusStatus> status;
    bool alive = true;
    std::map<std::string, BusPort::SnapshotSink, std::less<>> sinks;
    std::deque<std::pair<std::string, shm::DriveSnapshot>> snapshots;  // delivered in dispatch()
    std::deque<Call> calls;
    std::deque<std::pair<DrivePort::Done, std::expected<void, Error>>> answers;  // run in dispatch()
    int ports = 0;                                                               // BusPorts alive
    const Profile* profile = nullptr;

    void answer(Call& call, std::expected<void, Error> result) { answers.emplace_back(call.done, std::move(result)); }
};

class FakeDrive final : public DrivePort {
public:
    FakeDrive(Line& line, std::string name) : line_(line), name_(std::move(name)) {}
    ~FakeDrive() override { line_.sinks.erase(name_); }
    [[nodiscard]] const Profile* profile() const override { return line_.profile; }
    void write(std::uint16_t address, std::uint16_t raw, WriteOptions options, Done done) override {
        line_.calls.push_back(Call{.drive = name_,
                                   .what = "write",
                                   .address = address,
                                   .raw = raw,
                                   .deadline = options.deadline,
                                   .done = std::move(done)});
    }
    void keep_alive(Done done) override {
        line_.calls.push_back(Call{
            .drive = name_, .what = "keep_alive", .address = 0, .raw = 0, .deadline = {}, .done = std::move(done)});
    }
    void release_control(Done done) override {
        line_.calls.push_back(
            Call{.drive = name_, .what = "release", .address = 0, .raw = 0, .deadline = {}, .done = std::move(done)});
    }

private:
    Line& line_;
    std::string name_;
};

class FakeBus final : public BusPort {
public:
    explicit FakeBus(Line& line) : line_(line) { ++line_.ports; }
    ~FakeBus() override { --line_.ports; }
    [[nodiscard]] int descriptor() const override { return 99; }
    void dispatch() override {
        while (!line_.snapshots.empty()) {
            auto [name, s] = line_.snapshots.front();
            line_.snapshots.pop_front();
            if (auto it = line_.sinks.find(name); it != line_.sinks.end()) {
                it->second(s);
            }
        }
        while (!line_.answers.empty()) {
            auto [done, result] = std::move(line_.answers.front());
            line_.answers.pop_front();
            done(result);
        }
    }
    [[nodiscard]] std::optional<shm::BusStatus> status() const override { return line_.status; }
    [[nodiscard]] bool daemon_alive() const override { return line_.alive; }
    std::expected<std::unique_ptr<DrivePort>, std::string> drive(std::string_view name, SnapshotSink sink) override {
        line_.sinks[std::string(name)] = std::move(sink);
        return std::make_unique<FakeDrive>(line_, std::string(name));
    }

private:
    Line& line_;
};

class FakeDaemon final : public Daemon {
public:
    std::expected<std::unique_ptr<BusPort>, std::string> connect(std::string_view name) override {
        ++connects;
        if (!running) {
            return std::unexpected(std::string("drivebusd is not running"));
        }
        if (name != "line1") {
            return std::unexpected("drivebusd has no bus '" + std::string(name) + "'");
        }
        return std::make_unique<FakeBus>(line);
    }
    bool running = true;
    int connects = 0;
    Line line;
};

shm::BusStatus bus_status_of(std::initializer_list<std::string_view> drives) {
    shm::BusStatus s{};
    shm::assign(s.bus, "line1");
    s.up = 1;
    for (const auto name : drives) {
        shm::assign(s.drives[s.drive_count].name, name);
        s.drives[s.drive_count].health = shm::DriveHealth::Online;
        ++s.drive_count;
    }
    s.drives_online = s.drive_count;
    return s;
}

// The pump's snapshot with its output frequency (FD00, 0.01 Hz).
shm::DriveSnapshot pump(std::uint16_t fd00, std::uint64_t sequence) {
    shm::DriveSnapshot s{};
    shm::assign(s.bus, "line1");
    shm::assign(s.name, "pump");
    shm::assign(s.profile, "atv21");
    s.address = 1;
    s.health = shm::DriveHealth::Online;
    s.sequence = sequence;
    s.register_count = 1;
    s.registers[0].address = 0xFD00;
    s.registers[0].value = fd00;
    s.registers[0].valid = 1;
    s.registers[0].time_ns = static_cast<std::int64_t>(sequence);
    return s;
}

Error error(ErrorKind kind, std::string message) {
    Error e;
    e.kind = kind;
    e.message = std::move(message);
    return e;
}

class MqttRelay : public ::testing::Test {
protected:
    explicit MqttRelay(std::string_view extra = {})
        : config_(config(extra)),
          profile_(atv21()),
          relay_(
              std::make_unique<Relay>(config_, broker_, daemon_, [this](const RelayNote& n) { notes_.push_back(n); })) {
        daemon_.line.profile = &profile_;
    }

    Line& line() { return daemon_.line; }
    // One round of the loop at `t`: what the bus has, then the turn.
    void round(Time t, bool republish = false) {
        relay_->dispatch(t);
        relay_->turn(t, republish);
    }
    void reached(Time t) {
        line().status = bus_status_of({"pump", "fan"});
        round(t);
        ASSERT_TRUE(line().sinks.contains("pump"));
    }
    [[nodiscard]] std::vector<Published> states() const { return broker_.on("drivebus/board/line1/pump/state"); }
    [[nodiscard]] std::vector<Published> statuses() const { return broker_.on("drivebus/board/line1/status"); }
    [[nodiscard]] std::vector<Published> results(std::string_view drive) const {
        return broker_.on("drivebus/board/line1/" + std::string(drive) + "/result");
    }
    [[nodiscard]] int warnings_containing(std::string_view text) const {
        return static_cast<int>(std::ranges::count_if(notes_, [&](const RelayNote& n) {
            return n.level == RelayNote::Level::Warning && n.text.find(text) != std::string::npos;
        }));
    }
    void command(std::string_view drive, const Json& payload, Time at, bool retained = false) {
        relay_->message(Topics::Target{"line1", std::string(drive)}, payload.dump(), retained, kWall, at);
    }

    Config config_;
    Profile profile_;
    FakeBroker broker_;
    FakeDaemon daemon_;
    std::vector<RelayNote> notes_;
    std::unique_ptr<Relay> relay_;
};

TEST_F(MqttRelay, ABusNotReachedIsPublishedUnreachableAndTriedAgainWithBackOffWarnedOnce) {
    daemon_.running = false;
    round(kT0);
    EXPECT_EQ(daemon_.connects, 1);
    ASSERT_EQ(statuses().size(), 1U);
    EXPECT_EQ(statuses()[0].payload["drivebusd"], "unreachable");
    EXPECT_EQ(statuses()[0].payload["error"], "drivebusd is not running");
    EXPECT_TRUE(statuses()[0].retain);
    // From 1 s, doubling up to 30 s (docs/mqtt.md); no attempt comes sooner.
    const std::vector<std::chrono::milliseconds> delays = {1s, 2s, 4s, 8s, 16s, 30s, 30s};
    Time t = kT0;
    int attempts = 1;
    for (const auto delay : delays) {
        EXPECT_EQ(relay_->next_deadline(t), t + std::min<Time::duration>(delay, kIdleTurn));
        round(t + delay - 1ms);
        EXPECT_EQ(daemon_.connects, attempts) << "the attempt after " << delay.count() << " ms came early";
        t += delay;
        round(t);
        EXPECT_EQ(daemon_.connects, ++attempts);
    }
    EXPECT_EQ(warnings_containing("retrying with back-off"), 1);
    // The same reason is published again only once its period (10 s) has passed.
    EXPECT_LE(statuses().size(), 1U + static_cast<std::size_t>((t - kT0) / 10s));
    for (const auto& s : statuses()) {
        EXPECT_EQ(s.payload["error"], "drivebusd is not running");
    }
    daemon_.running = true;
    line().status = bus_status_of({"pump", "fan"});
    round(t + delays.back());
    EXPECT_EQ(statuses().back().payload["drivebusd"], "running");
    EXPECT_EQ(
        std::ranges::count_if(notes_, [](const RelayNote& n) { return n.text == "bus line1: bridging 2 drives"; }), 1);
    EXPECT_EQ(line().ports, 1);
}

TEST_F(MqttRelay, ABusWhoseFirstStatusNeverComesHoldsNothingAndIsGivenUpAfterTwoSeconds) {
    round(kT0);
    EXPECT_EQ(daemon_.connects, 1);
    EXPECT_EQ(line().ports, 1);
    EXPECT_TRUE(statuses().empty());                                         // nothing known to say yet
    EXPECT_EQ(relay_->next_deadline(kT0 + 100ms), kT0 + 100ms + kIdleTurn);  // the status wakes it sooner
    round(kT0 + kFirstStatusWait - 1ms);
    EXPECT_EQ(line().ports, 1);
    round(kT0 + kFirstStatusWait);
    EXPECT_EQ(line().ports, 0);
    ASSERT_EQ(statuses().size(), 1U);
    EXPECT_EQ(statuses()[0].payload["drivebusd"], "unreachable");
    EXPECT_NE(statuses()[0].payload["error"].get<std::string>().find("no status"), std::string::npos);
    EXPECT_EQ(warnings_containing("no status"), 1);
    // Tried again; this time the status comes, and the drives with it.
    line().status = bus_status_of({"pump", "fan"});
    round(relay_->next_deadline(kT0 + kFirstStatusWait));
    EXPECT_EQ(daemon_.connects, 2);
    EXPECT_TRUE(line().sinks.contains("pump"));
    EXPECT_TRUE(line().sinks.contains("fan"));
    EXPECT_EQ(statuses().back().payload["drivebusd"], "running");
}

TEST_F(MqttRelay, AConfiguredDriveDrivebusdDoesNotHaveIsWarnedAndTheOthersBridged) {
    line().status = bus_status_of({"pump"});
    round(kT0);
    EXPECT_EQ(warnings_containing("drivebusd has no drive 'fan' (configured here)"), 1);
    EXPECT_TRUE(line().sinks.contains("pump"));
    command("fan", Json{{"id", "f"}, {"verb", "stop"}}, kT0);
    ASSERT_EQ(results("fan").size(), 1U);
    EXPECT_EQ(results("fan")[0].payload["reason"], "unknown_drive");
}

TEST_F(MqttRelay, StatesArePublishedOnChangesBeyondTheDeadbandAndAtLeastEveryPeriod) {
    reached(kT0);
    line().snapshots.emplace_back("pump", pump(4000, 1));
    round(kT0 + 10ms);
    ASSERT_EQ(states().size(), 1U);
    EXPECT_TRUE(states()[0].retain);
    EXPECT_EQ(states()[0].qos, 0);
    EXPECT_DOUBLE_EQ(states()[0].payload["registers"]["FD00"]["value"].get<double>(), 40.0);
    // 0.5 Hz: inside the pump's deadband of 1.0.
    line().snapshots.emplace_back("pump", pump(4050, 2));
    round(kT0 + 20ms);
    EXPECT_EQ(states().size(), 1U);
    // 1.5 Hz from what was published: out.
    line().snapshots.emplace_back("pump", pump(4150, 3));
    round(kT0 + 30ms);
    ASSERT_EQ(states().size(), 2U);
    EXPECT_DOUBLE_EQ(states()[1].payload["registers"]["FD00"]["value"].get<double>(), 41.5);
    // No change: again once its period (10 s) has passed, and the loop knows when.
    EXPECT_LE(relay_->next_deadline(kT0 + 40ms), kT0 + 30ms + 10s);
    round(kT0 + 30ms + 10s - 1ms);
    EXPECT_EQ(states().size(), 2U);
    round(kT0 + 30ms + 10s);
    EXPECT_EQ(states().size(), 3U);
}

TEST_F(MqttRelay, ABrokerThatStallsMissesTheStatesBetweenButNeverTheLastChange) {
    reached(kT0);
    line().snapshots.emplace_back("pump", pump(1000, 1));
    round(kT0 + 10ms);
    ASSERT_EQ(states().size(), 1U);
    broker_.stalled = true;
    Time t = kT0 + 10ms;
    for (std::uint16_t hz = 20; hz <= 50; hz += 10) {
        t += 100ms;
        line().snapshots.emplace_back("pump", pump(static_cast<std::uint16_t>(hz * 100), hz));
        round(t);
    }
    EXPECT_EQ(states().size(), 1U);
    EXPECT_GE(broker_.refused, 4);
    // Unstalled: the next round publishes the newest, with no new snapshot to prompt it.
    broker_.stalled = false;
    EXPECT_LE(relay_->next_deadline(t), t + kIdleTurn);
    round(t + 1s);
    ASSERT_EQ(states().size(), 2U);
    EXPECT_DOUBLE_EQ(states()[1].payload["registers"]["FD00"]["value"].get<double>(), 50.0);
}

TEST_F(MqttRelay, ABrokerConnectedAgainGetsEveryRetainedMessageAgain) {
    reached(kT0);
    line().snapshots.emplace_back("pump", pump(1000, 1));
    round(kT0 + 10ms);
    const auto states_before = states().size();
    const auto statuses_before = statuses().size();
    broker_.up = false;
    round(kT0 + 1s);
    broker_.up = true;
    round(kT0 + 2s, true);
    EXPECT_EQ(states().size(), states_before + 1);
    EXPECT_EQ(statuses().size(), statuses_before + 1);
}

TEST_F(MqttRelay, ASilentDrivebusdIsShownOnTheBusStatus) {
    reached(kT0);
    ASSERT_EQ(statuses().back().payload["drivebusd"], "running");
    line().alive = false;
    round(kT0 + 100ms);
    EXPECT_EQ(statuses().back().payload["drivebusd"], "silent");
}

TEST_F(MqttRelay, ACommandIsCarriedOutStepByStepAsTheDriveAnswersAndItsResultPublished) {
    reached(kT0);
    command("pump", Json{{"id", "c-1"}, {"frequency", 40}, {"verb", "run"}}, kT0 + 10ms);
    // One action at a time: the reference first, with the command's time left as its deadline.
    ASSERT_EQ(line().calls.size(), 1U);
    EXPECT_EQ(line().calls[0].what, "write");
    EXPECT_EQ(line().calls[0].address, 0xFA01);
    EXPECT_EQ(line().calls[0].raw, 4000);
    ASSERT_TRUE(line().calls[0].deadline);
    EXPECT_LE(*line().calls[0].deadline, 10s);
    line().answer(line().calls[0], {});
    line().calls.pop_front();
    EXPECT_TRUE(results("pump").empty());
    relay_->dispatch(kT0 + 30ms);
    ASSERT_EQ(line().calls.size(), 1U);
    EXPECT_EQ(line().calls[0].address, 0xFA00);
    line().answer(line().calls[0], {});
    line().calls.pop_front();
    relay_->dispatch(kT0 + 50ms);
    ASSERT_EQ(results("pump").size(), 1U);
    const auto r = results("pump")[0];
    EXPECT_EQ(r.payload["ok"], true) << r.payload.dump();
    EXPECT_EQ(r.payload["id"], "c-1");
    EXPECT_EQ(r.qos, 1);
    EXPECT_FALSE(r.retain);
    // The command's arrival renews the lease too: a keep-alive whose answer nobody awaits.
    ASSERT_EQ(line().calls.size(), 1U);
    EXPECT_EQ(line().calls[0].what, "keep_alive");
    line().answer(line().calls[0], std::unexpected(error(ErrorKind::NotPermitted, "no lease")));
    line().calls.pop_front();
    relay_->dispatch(kT0 + 60ms);
    EXPECT_EQ(results("pump").size(), 1U);
    EXPECT_TRUE(line().calls.empty());
    EXPECT_EQ(relay_->commands().commands, 1U);
}

// The timing case: the lease ran out (or another client took it over) between the command's
// first write and its second. The second is refused; nothing after it is tried, and the result
// says what had been done.
TEST_F(MqttRelay, ACommandWhoseLeaseRunsOutMidwayStopsThereAndSaysWhatWasDone) {
    reached(kT0);
    command("pump", Json{{"id", "c-2"}, {"frequency", 30}, {"verb", "run"}}, kT0);
    line().answer(line().calls[0], {});
    line().calls.pop_front();
    relay_->dispatch(kT0 + 20ms);
    ASSERT_EQ(line().calls.size(), 1U);
    line().answer(line().calls[0], std::unexpected(error(ErrorKind::NotPermitted,
                                                         "drive 'pump' is controlled by "
                                                         "another client")));
    line().calls.pop_front();
    relay_->dispatch(kT0 + 1200ms);
    ASSERT_EQ(results("pump").size(), 1U);
    const auto r = results("pump")[0].payload;
    EXPECT_EQ(r["ok"], false) << r.dump();
    EXPECT_EQ(r["reason"], "not_permitted") << r.dump();
    EXPECT_NE(r.dump().find("FA01"), std::string::npos) << "the result names the write that was done: " << r.dump();
    EXPECT_TRUE(line().calls.empty());
}

TEST_F(MqttRelay, ACommandToADriveNotEnabledIsRefusedSayingSoAndNeverActs) {
    reached(kT0);
    command("fan", Json{{"id", 5}, {"verb", "run"}}, kT0);
    ASSERT_EQ(results("fan").size(), 1U);
    const auto r = results("fan")[0].payload;
    EXPECT_EQ(r["ok"], false);
    EXPECT_EQ(r["id"], 5);
    EXPECT_EQ(r["reason"], "commands_disabled");
    EXPECT_NE(r["error"].get<std::string>().find("not enabled"), std::string::npos);
    EXPECT_TRUE(line().calls.empty());
}

TEST_F(MqttRelay, ACommandPastItsTimeIsRefusedAsExpiredAndNeverActs) {
    reached(kT0);
    const auto ms = [](WallTime t) {
        return std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
    };
    // Past its not_after, sent a minute ago (the bridge's limit is 10 s), older than its own max_age.
    command("pump", Json{{"id", "past"}, {"verb", "run"}, {"not_after", "2020-01-01T00:00:00Z"}}, kT0);
    command("pump", Json{{"id", "old"}, {"verb", "run"}, {"frequency", 20}, {"sent_at", ms(kWall - 60s)}}, kT0);
    command("pump", Json{{"id", "own"}, {"verb", "run"}, {"sent_at", ms(kWall - 3s)}, {"max_age", "1s"}}, kT0);
    ASSERT_EQ(results("pump").size(), 3U);
    for (const auto& r : results("pump")) {
        EXPECT_EQ(r.payload["ok"], false) << r.payload.dump();
        EXPECT_EQ(r.payload["reason"], "expired") << r.payload.dump();
    }
    EXPECT_TRUE(line().calls.empty());
    // Within its time, it acts.
    command("pump", Json{{"id", "fresh"}, {"frequency", 30}, {"sent_at", ms(kWall)}, {"max_age", "4s"}}, kT0);
    ASSERT_EQ(line().calls.size(), 1U);
    EXPECT_EQ(line().calls[0].raw, 3000);
}

// A command waiting behind a slow one runs out of time in the bridge's queue: refused when its
// turn comes, never sent late.
TEST_F(MqttRelay, ACommandWhoseTimeRunsOutWhileQueuedIsRefusedWhenItsTurnComes) {
    reached(kT0);
    command("pump", Json{{"id", "slow"}, {"frequency", 10}}, kT0);
    ASSERT_EQ(line().calls.size(), 1U);
    command("pump", Json{{"id", "behind"}, {"verb", "run"}, {"max_age", "300ms"}}, kT0);
    EXPECT_EQ(line().calls.size(), 1U);  // one at a time
    line().answer(line().calls[0], {});
    line().calls.pop_front();
    relay_->dispatch(kT0 + 500ms);  // the slow one's answer comes after 500 ms
    const auto all = results("pump");
    ASSERT_GE(all.size(), 1U);
    const auto behind = std::ranges::find_if(all, [](const Published& p) { return p.payload["id"] == "behind"; });
    ASSERT_NE(behind, all.end());
    EXPECT_EQ(behind->payload["reason"], "expired") << behind->payload.dump();
    for (const auto& c : line().calls) {
        EXPECT_NE(c.address, 0xFA00) << "the run was sent after its time";
    }
}

TEST_F(MqttRelay, ADroppedRelayEndsItsDrivesSubscriptionsAndItsBuses) {
    reached(kT0);
    command("pump", Json{{"id", "c"}, {"frequency", 10}}, kT0);
    ASSERT_EQ(line().calls.size(), 1U);
    relay_.reset();
    EXPECT_TRUE(line().sinks.empty());
    EXPECT_EQ(line().ports, 0);
}

// The network thread's hand-over, flooded: the Commander's queue and as many again, plus 16,
// are kept in order; the rest come back to be refused as busy, with their ids.
TEST(MqttInbox, AFloodBeyondItsBoundIsGivenBackToBeRefusedAsBusy) {
    Inbox inbox(4);
    ASSERT_EQ(inbox.bound(), 24U);
    const auto message = [](int i) {
        return Inbound{Topics::Target{"line1", "pump"}, Json{{"id", "f" + std::to_string(i)}, {"frequency", 10}}.dump(),
                       false, kWall, kT0};
    };
    std::vector<Inbound> refused;
    for (int i = 0; i < 300; ++i) {
        if (auto back = inbox.offer(message(i))) {
            refused.push_back(std::move(*back));
        }
    }
    EXPECT_EQ(inbox.size(), 24U);
    ASSERT_EQ(refused.size(), 276U);
    const auto busy = refused_busy(refused.front(), 4096);
    EXPECT_EQ(busy.bus, "line1");
    EXPECT_EQ(busy.drive, "pump");
    EXPECT_EQ(busy.payload["id"], "f24");
    EXPECT_EQ(busy.payload["reason"], "busy");
    EXPECT_EQ(busy.payload["ok"], false);
    // Too large to read: refused without its id.
    Inbound huge = message(0);
    huge.payload = std::string(200000, '{');
    EXPECT_TRUE(refused_busy(huge, 4096).payload["id"].is_null());
    const auto taken = inbox.take();
    ASSERT_EQ(taken.size(), 24U);
    for (std::size_t i = 0; i < taken.size(); ++i) {
        EXPECT_EQ(Json::parse(taken[i].payload)["id"], "f" + std::to_string(i));
    }
    EXPECT_EQ(inbox.size(), 0U);
    EXPECT_FALSE(inbox.offer(message(1000)));  // room again
}

}  // namespace
}  // namespace drivebus::mqtt
