// SPDX-License-Identifier: Apache-2.0
// How much silence drivebusd's bus thread leaves before each request beyond the t3.5 the
// protocol requires, measured on the simulator's side of the pty: from the end of the last
// character the simulator sent to the first byte of the next request. The bus is saturated
// (a poll group always due), so every gap is the loop's reaction time.
//
// A silence below t3.5 on the simulator's side can only follow a reply the master saw broken:
// the pty delivers bytes through a kernel worker, and a byte held back there longer than t3.5
// looks, to the master, like the end of the line's activity (as a USB adapter's latency would).
// The table shows both counts.
//
//   bench_master_gap [--seconds S] [--realtime PRIO]
#include <sched.h>

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "sim_process.hpp"

using namespace drivebus;
using namespace std::chrono_literals;

namespace {

struct Row {
    std::string line;
    std::string silences;
    master::BusStatus status;
};

std::string field(const std::string& summary, const std::string& key) {
    const auto at = summary.find(key + "=");
    if (at == std::string::npos) {
        return "?";
    }
    const auto end = summary.find(' ', at);
    return summary.substr(at + key.size() + 1,
                          end == std::string::npos ? std::string::npos : end - at - key.size() - 1);
}

Row run(std::uint32_t baud, double seconds, int realtime) {
    std::vector<std::string> args{"--drive", "2:atv58", "--baud", std::to_string(baud), "--turnaround", "1ms"};
    if (realtime > 0) {
        args.insert(args.end(), {"--realtime", std::to_string(realtime - 1)});
    }
    test::SimProcess sim(args);
    auto atv58 = test::load("atv58");
    config::BusConfig config = test::bus<config::BusConfig>({baud, 8, rtu::Parity::None, 1});
    config.device = sim.link();
    auto fan = test::drive("fan", 2, atv58);
    fan.polls.push_back(test::poll(*atv58, {"W450", "W451", "W452", "W453"}, 1ms));
    config.drives.push_back(fan);
    bus::LoopOptions options;
    if (realtime > 0) {
        config::RealtimeConfig rt;
        rt.mode = config::RealtimeMode::BestEffort;
        rt.priority = realtime;
        options.realtime = rt;
    }
    bus::BusLoop loop(config, {}, options);
    if (!loop.start()) {
        std::exit(1);
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    loop.stop();
    if (std::getenv("BENCH_VERBOSE") != nullptr) {
        std::fprintf(stderr, "simulator: %s\nbus: transmissions=%llu replies=%llu foreign=%llu crc=%llu gap=%llu\n",
                     sim.command("stats").c_str(),
                     static_cast<unsigned long long>(loop.status().counters.transmissions),
                     static_cast<unsigned long long>(loop.status().counters.replies),
                     static_cast<unsigned long long>(loop.status().counters.foreign),
                     static_cast<unsigned long long>(loop.status().counters.crc_errors),
                     static_cast<unsigned long long>(loop.status().counters.gap_errors));
    }
    return {std::to_string(baud) + " 8N1", sim.command("silences"), loop.status()};
}

}  // namespace

int main(int argc, char** argv) {
    double seconds = 10.0;
    int realtime = 0;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string key = argv[i];
        if (key == "--seconds") {
            seconds = std::stod(argv[i + 1]);
        } else if (key == "--realtime") {
            realtime = std::stoi(argv[i + 1]);
        } else {
            std::fprintf(stderr, "usage: bench_master_gap [--seconds S] [--realtime PRIO]\n");
            return 2;
        }
    }
    std::printf("silence before each request beyond t3.5, seen by the simulator (bus saturated, %s)\n",
                realtime > 0 ? "SCHED_FIFO" : "normal scheduling");
    std::printf(
        "| line | requests | t3.5 | below t3.5 | replies seen broken | after a simulator slip | min | p50 beyond t3.5 "
        "| p99 beyond t3.5 | max beyond t3.5 |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
    int failures = 0;
    for (const std::uint32_t baud : {19200U, 115200U}) {
        const Row row = run(baud, seconds, realtime);
        const long t35 = std::stol(field(row.silences, "t35_us"));
        auto beyond = [&](const char* key) {
            return std::to_string(std::stol(field(row.silences, key)) - t35) + " us";
        };
        const auto& c = row.status.counters;
        const unsigned long long broken = c.crc_errors + c.gap_errors + c.noise + c.timeouts + c.malformed;
        std::printf("| %s | %s | %ld us | %s | %llu | %s | %s us | %s | %s | %s |\n", row.line.c_str(),
                    field(row.silences, "count").c_str(), t35, field(row.silences, "short").c_str(), broken,
                    field(row.silences, "after_slip").c_str(), field(row.silences, "min_us").c_str(),
                    beyond("p50_us").c_str(), beyond("p99_us").c_str(), beyond("max_us").c_str());
        // A short silence after a clean reply would be the master's fault.
        failures += std::stoull(field(row.silences, "short")) <= broken ? 0 : 1;
    }
    return failures == 0 ? 0 : 1;
}
