// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt's cost and latency (docs/performance.md, "MQTT bridge"): 31 Altivar 58 drives
// simulated at 19200 8N1, polled by drivebusd as fast as the line allows, every state published
// by the bridge to a mosquitto broker on loopback, and one subscriber.
//
//   bench_mqtt [--seconds S] [--smoke]
//
// Reported: the bridge's CPU share (utime+stime over the run) and peak RSS; the end-to-end
// latency from the simulator's write of a reply's last byte (drivebus-sim --tx-log) to the
// subscriber's receipt of the state message carrying that reply's values (p50/p99); and, in
// the same run through the same broker, the broker-only floor: a publish → subscribe round
// trip of a small message from another client. To make every poll news, the benchmark changes
// one drive's W450 through the simulator's control socket every 20 ms (round robin); a state
// is matched to its reply by the reply time drivebusd recorded (the message's polled_ns). The
// broker runs with set_tcp_nodelay, and both publishers with TCP_NODELAY.
// Nothing here asserts on speed.
#include <mosquitto.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "broker.hpp"
#include "sim_process.hpp"
#include "stats.hpp"
#include "suite_tools.hpp"

namespace {

using namespace drivebus;
using namespace std::chrono_literals;
using bench::now_ns;
using Json = nlohmann::json;
namespace fs = std::filesystem;

constexpr int kDrives = 31;
constexpr auto kChangeEvery = 20ms;
constexpr auto kFloorEvery = 10ms;
constexpr std::int64_t kMatchWindowNs = 5'000'000;

struct Received {
    std::int64_t ns = 0;
    std::string topic;
    std::string payload;
};

// A libmosquitto subscriber that timestamps each message on arrival (its network thread).
class Subscriber {
public:
    Subscriber(int port, const std::vector<std::string>& filters) : filters_(filters) {
        mosq_ = mosquitto_new(nullptr, true, this);
        mosquitto_connect_callback_set(mosq_, [](mosquitto* m, void* self, int rc) {
            if (rc == 0) {
                for (const auto& f : static_cast<Subscriber*>(self)->filters_) {
                    mosquitto_subscribe(m, nullptr, f.c_str(), 0);
                }
                static_cast<Subscriber*>(self)->subscribed_ = true;
            }
        });
        mosquitto_message_callback_set(mosq_, [](mosquitto*, void* self, const mosquitto_message* msg) {
            const auto t = now_ns();
            auto& s = *static_cast<Subscriber*>(self);
            std::lock_guard lock(s.mutex_);
            s.received_.push_back(Received{
                t, msg->topic,
                std::string(static_cast<const char*>(msg->payload), static_cast<std::size_t>(msg->payloadlen))});
        });
        mosquitto_connect(mosq_, "127.0.0.1", port, 30);
        mosquitto_loop_start(mosq_);
    }
    ~Subscriber() {
        mosquitto_disconnect(mosq_);
        mosquitto_loop_stop(mosq_, true);
        mosquitto_destroy(mosq_);
    }
    Subscriber(const Subscriber&) = delete;
    Subscriber& operator=(const Subscriber&) = delete;
    Subscriber(Subscriber&&) = delete;
    Subscriber& operator=(Subscriber&&) = delete;

    std::vector<Received> take() {
        std::lock_guard lock(mutex_);
        return std::move(received_);
    }
    [[nodiscard]] bool subscribed() const { return subscribed_.load(); }

private:
    std::vector<std::string> filters_;
    mosquitto* mosq_ = nullptr;
    std::mutex mutex_;
    std::vector<Received> received_;
    std::atomic<bool> subscribed_{false};
};

struct ProcSample {
    double cpu_s = 0;
    long rss_kb = 0;
    long hwm_kb = 0;
};

ProcSample proc_sample(int pid) {
    ProcSample s;
    const std::string stat = bench::slurp(fs::path("/proc") / std::to_string(pid) / "stat");
    if (const auto close = stat.rfind(')'); close != std::string::npos) {
        std::istringstream in(stat.substr(close + 2));
        std::vector<std::string> f;
        for (std::string x; in >> x;) {
            f.push_back(x);
        }
        if (f.size() > 13) {
            s.cpu_s = static_cast<double>(std::stoll(f[11]) + std::stoll(f[12])) /
                      static_cast<double>(::sysconf(_SC_CLK_TCK));
        }
    }
    std::istringstream status(bench::slurp(fs::path("/proc") / std::to_string(pid) / "status"));
    for (std::string line; std::getline(status, line);) {
        if (line.rfind("VmRSS:", 0) == 0) {
            s.rss_kb = std::atol(line.c_str() + 6);
        } else if (line.rfind("VmHWM:", 0) == 0) {
            s.hwm_kb = std::atol(line.c_str() + 6);
        }
    }
    return s;
}

std::string drive_tables() {
    std::string out;
    for (int a = 1; a <= kDrives; ++a) {
        out += "  [[bus.drive]]\n  name = \"d" + std::to_string(a) + "\"\n  address = " + std::to_string(a) +
               "\n  profile = \"atv58\"\n    [[bus.drive.poll]]\n    registers = [\"W450\", \"W451\", \"W452\", "
               "\"W453\"]\n    period = \"1ms\"\n";
    }
    return out;
}

std::string row(const std::string& what, const bench::Summary& s, const std::string& notes) {
    char text[512];
    std::snprintf(text, sizeof text, "| %s | %zu | %.0f | %.0f | %.0f | %s |", what.c_str(), s.count, s.p50, s.p99,
                  s.max, notes.c_str());
    return text;
}

int run(double seconds) {
    const fs::path dir = bench::fresh_dir("mqtt");
    if (!test::wait_until([] { return test::roudi_gone(); }, 60s)) {
        throw bench::Failure("a RouDi runs on this machine: stop it first");
    }
    test::Broker broker;
    const fs::path simdir = dir / "sim";
    fs::create_directories(simdir);
    std::vector<std::string> sim_args{"--baud",       "19200", "--parity", "none",
                                      "--turnaround", "1ms",   "--tx-log", (simdir / "tx.log").string()};
    for (int a = 1; a <= kDrives; ++a) {
        sim_args.insert(sim_args.end(), {"--drive", std::to_string(a) + ":atv58"});
    }
    test::SimProcess sim(sim_args, simdir);
    const fs::path daemon_config = dir / "drivebusd.toml";
    std::ofstream(daemon_config) << "[realtime]\nmode = \"off\"\nlock_memory = false\n[ipc]\nroudi = \"embedded\"\n"
                                 << "[[bus]]\nname = \"benchm\"\ndevice = \"" << sim.link().string()
                                 << "\"\nbaud = 19200\nparity = \"none\"\ndirection = \"none\"\n"
                                 << "response_timeout = \"100ms\"\nretries = 2\n"
                                 << drive_tables();
    test::Child daemon({DRIVEBUSD_PATH, "--config", daemon_config.string()});
    if (!test::wait_until([&] { return daemon.output().find("running:") != std::string::npos; }, 20s)) {
        throw bench::Failure("drivebusd did not come up: " + daemon.output());
    }
    const fs::path bridge_config = dir / "mqtt.toml";
    // A period longer than the run: every message the subscriber gets is a change.
    std::ofstream(bridge_config) << "node = \"bench\"\n[broker]\nhost = \"127.0.0.1\"\nport = " << broker.port()
                                 << "\n[[bus]]\nname = \"benchm\"\nperiod = \"60min\"\n";
    Subscriber sub(broker.port(), {"drivebus/bench/benchm/+/state", "bench/floor"});
    test::Child bridge({DRIVEBUS_MQTT_PATH, "--config", bridge_config.string()});
    if (!test::wait_until([&] { return bridge.output().find("bridging 31 drives") != std::string::npos; }, 30s) ||
        !test::wait_until([&] { return sub.subscribed(); }, 10s)) {
        throw bench::Failure("the bridge did not come up: " + bridge.output());
    }
    std::this_thread::sleep_for(2s);  // the first states of every drive are out
    (void)sub.take();

    // The broker-only floor, from another client, in the same run.
    std::atomic<bool> stop{false};
    std::thread floor([&] {
        mosquitto* pub = mosquitto_new(nullptr, true, nullptr);
        mosquitto_int_option(pub, MOSQ_OPT_TCP_NODELAY, 1);  // as the bridge
        mosquitto_connect(pub, "127.0.0.1", broker.port(), 30);
        mosquitto_loop_start(pub);
        while (!stop.load()) {
            const auto text = std::to_string(now_ns());
            mosquitto_publish(pub, nullptr, "bench/floor", static_cast<int>(text.size()), text.data(), 0, false);
            std::this_thread::sleep_for(kFloorEvery);
        }
        mosquitto_disconnect(pub);
        mosquitto_loop_stop(pub, true);
        mosquitto_destroy(pub);
    });
    const int pid = bridge.pid();
    const auto s0 = proc_sample(pid);
    const auto t0 = now_ns();
    const auto end = t0 + static_cast<std::int64_t>(seconds * 1e9);
    long peak_rss = s0.rss_kb;
    std::uint64_t changes = 0;
    for (int a = 1; now_ns() < end; a = a % kDrives + 1) {
        (void)sim.command("set " + std::to_string(a) + " W450 " + std::to_string(changes++ % 60000));
        peak_rss = std::max(peak_rss, proc_sample(pid).rss_kb);
        std::this_thread::sleep_for(kChangeEvery);
    }
    const auto s1 = proc_sample(pid);
    const auto t1 = now_ns();
    stop = true;
    floor.join();
    std::this_thread::sleep_for(500ms);  // the last messages arrive
    const auto received = sub.take();
    const std::string sim_stats = sim.command("stats");
    bridge.stop();
    daemon.stop();
    sim.stop();

    const auto tx = bench::read_events(simdir / "tx.log");
    std::vector<double> e2e;
    std::vector<double> floor_us;
    std::vector<double> bridge_us;
    std::size_t states = 0;
    std::size_t unmatched = 0;
    for (const auto& m : received) {
        if (m.topic == "bench/floor") {
            floor_us.push_back(bench::us(m.ns - std::stoll(m.payload)));
            continue;
        }
        ++states;
        const auto j = Json::parse(m.payload, nullptr, false);
        if (!j.is_object() || !j["polled_ns"].is_number_integer()) {
            ++unmatched;
            continue;
        }
        const std::int64_t polled = j["polled_ns"].get<std::int64_t>();
        const int address = j.value("address", 0);
        // The simulator's write of that reply: the event to that drive nearest to the reply's end
        // as drivebusd timed it (from its characters' timestamps: it may come before the
        // simulator's clock reading after its write()).
        auto it = std::ranges::lower_bound(tx, polled - kMatchWindowNs, {}, &bench::Event::ns);
        std::optional<std::int64_t> reply;
        for (; it != tx.end() && it->ns <= polled + kMatchWindowNs; ++it) {
            if (it->address == address && (!reply || std::llabs(it->ns - polled) < std::llabs(*reply - polled))) {
                reply = it->ns;
            }
        }
        if (!reply) {
            ++unmatched;
            continue;
        }
        bridge_us.push_back(bench::us(m.ns - polled));
        e2e.push_back(bench::us(m.ns - *reply));
    }
    const double wall = static_cast<double>(t1 - t0) / 1e9;
    const double share = 100.0 * (s1.cpu_s - s0.cpu_s) / wall;
    std::printf(
        "## MQTT bridge: 31 drives at 19200 8N1, as fast as the line allows, states to mosquitto on loopback\n\n");
    std::printf(
        "bridge CPU %.2f%% of one core over %.0f s (utime+stime); peak VmRSS %.1f MiB (VmHWM %.1f MiB); "
        "%zu state messages (%.1f/s) for %llu changes; simulator: %s\n\n",
        share, wall, static_cast<double>(peak_rss) / 1024.0, static_cast<double>(s1.hwm_kb) / 1024.0, states,
        static_cast<double>(states) / wall, static_cast<unsigned long long>(changes), sim_stats.c_str());
    std::printf("| path | samples | p50 µs | p99 µs | max µs | notes |\n|---|---|---|---|---|---|\n");
    std::printf("%s\n", row("simulator writes a reply's last byte → subscriber holds the state message",
                            bench::summarize(e2e), std::to_string(unmatched) + " messages not matched to a reply")
                            .c_str());
    std::printf("%s\n", row("of which: drivebusd's reply time → subscriber (drivebusd, iceoryx, bridge, broker)",
                            bench::summarize(bridge_us), "")
                            .c_str());
    std::printf("%s\n", row("broker floor: publish → subscribe through the same broker, another client",
                            bench::summarize(floor_us), "QoS 0, one message every 10 ms during the run")
                            .c_str());
    return e2e.empty() ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
    double seconds = 30.0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--smoke") {
            seconds = 3.0;
        } else if (a == "--seconds" && i + 1 < argc) {
            seconds = std::stod(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: bench_mqtt [--seconds S] [--smoke]\n");
            return 2;
        }
    }
    mosquitto_lib_init();
    try {
        const int rc = run(seconds);
        mosquitto_lib_cleanup();
        return rc;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_mqtt: %s\n", e.what());
        return 1;
    }
}
