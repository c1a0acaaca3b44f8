// SPDX-License-Identifier: Apache-2.0
// How a paced drivebus-sim reply arrives at the master side of the pty: the spacing between
// consecutive reply characters as the master reads them, against the character time of the
// line (19200 8N1: 520.8 us). The master spins on non-blocking reads so that each character
// gets its own timestamp.
//
//   bench_sim_pacing [--transactions N] [--baud B] [--realtime PRIO]
//
// With --realtime both the simulator and this reader run SCHED_FIFO (root or CAP_SYS_NICE).
#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "rtu/codec.hpp"
#include "serial/termios.hpp"
#include "sim_process.hpp"
#include "stats.hpp"

using namespace drivebus;
using namespace std::chrono_literals;

int main(int argc, char** argv) {
    int transactions = 1000;
    std::uint32_t baud = 19200;
    int realtime = 0;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string key = argv[i];
        if (key == "--transactions") {
            transactions = std::stoi(argv[i + 1]);
        } else if (key == "--realtime") {
            realtime = std::stoi(argv[i + 1]);
        } else if (key == "--baud") {
            baud = static_cast<std::uint32_t>(std::stoul(argv[i + 1]));
        } else {
            std::fprintf(stderr, "usage: bench_sim_pacing [--transactions N] [--baud B] [--realtime PRIO]\n");
            return 2;
        }
    }
    const rtu::LineFormat format{baud, 8, rtu::Parity::None, 1};
    const auto timing = rtu::character_timing(format).value();
    std::vector<std::string> args{"--drive", "2:atv58", "--baud", std::to_string(baud)};
    bool rt = false;
    if (realtime > 0) {
        args.insert(args.end(), {"--realtime", std::to_string(realtime)});
        sched_param param{};
        param.sched_priority = realtime - 1;  // the reader just below the simulator
        rt = ::sched_setscheduler(0, SCHED_FIFO, &param) == 0;
    }
    test::SimProcess sim(args);

    sys::UniqueFd fd(::open(sim.link().c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC));
    if (!fd || !serial::configure_line(fd.get(), format, serial::ErrorMarking::Off)) {
        std::fprintf(stderr, "cannot open %s\n", sim.link().c_str());
        return 1;
    }
    const rtu::RequestAdu request{2, rtu::ReadHoldingRegisters{450, 10}};
    const auto adu = rtu::encode_request(request).value();
    constexpr std::size_t kReply = 25;

    std::vector<double> spacing_us;
    std::vector<double> burst;  // characters that arrived in the same read as the previous one
    int failed = 0;
    for (int t = 0; t < transactions; ++t) {
        // Keep the line silent for t3.5 (and a little) before each request.
        const auto quiet_until = sys::now() + timing.t3_5 + 200us;
        while (sys::now() < quiet_until) {
        }
        if (::write(fd.get(), adu.bytes().data(), adu.size()) != static_cast<ssize_t>(adu.size())) {
            return 1;
        }
        std::vector<rtu::Instant> times;
        const auto deadline = sys::now() + 500ms;
        while (times.size() < kReply && sys::now() < deadline) {
            std::uint8_t b[64];
            const auto n = ::read(fd.get(), b, sizeof b);
            if (n > 0) {
                const auto now = sys::now();
                for (ssize_t i = 0; i < n; ++i) {
                    times.push_back(now);
                }
            }
        }
        if (times.size() != kReply) {
            ++failed;
            continue;
        }
        for (std::size_t i = 1; i < times.size(); ++i) {
            spacing_us.push_back(std::chrono::duration<double, std::micro>(times[i] - times[i - 1]).count());
        }
    }
    const auto s = bench::summarize(spacing_us);
    const double c_us = std::chrono::duration<double, std::micro>(timing.character).count();
    std::printf("reply character spacing at the master, %s, %d transactions of %zu-byte replies, %s\n",
                serial::describe(format).c_str(), transactions, kReply, rt ? "SCHED_FIFO" : "normal scheduling");
    std::printf("| samples | character time | p50 | p99 | max | min |\n|---|---|---|---|---|---|\n");
    std::printf("| %zu | %.1f us | %.1f us | %.1f us | %.1f us | %.1f us |\n", s.count, c_us, s.p50, s.p99, s.max,
                s.min);
    if (failed > 0) {
        std::printf("%d transactions got no complete reply\n", failed);
    }
    return failed > 0 ? 1 : 0;
}
