// SPDX-License-Identifier: Apache-2.0
#include "floors.hpp"

#include <pty.h>
#include <signal.h>
#include <sys/epoll.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>
#include <atomic>
#include <sstream>
#include <thread>

#include "sim_process.hpp"

namespace drivebus::bench {

namespace {

using namespace std::chrono_literals;

// One byte at a time written to a pty's master, read on its slave by a thread blocked in
// epoll_wait, as drivebusd's bus thread reads: the kernel's pty worker and one wake-up.
std::vector<double> pty_hop(std::size_t n, std::chrono::microseconds pause) {
    int master = -1;
    int slave = -1;
    if (::openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) {
        throw Failure("openpty failed");
    }
    termios raw{};
    ::tcgetattr(slave, &raw);
    ::cfmakeraw(&raw);
    ::tcsetattr(slave, TCSANOW, &raw);
    // The writer sleeps between bytes, as the simulator does between replies; the reader
    // takes each byte's time as its read returns. The i-th byte read is the i-th written.
    std::vector<std::int64_t> sent(n, 0);
    std::vector<std::int64_t> read_at;
    read_at.reserve(n);
    std::atomic<bool> writing{true};
    std::thread reader([&] {
        const int ep = ::epoll_create1(EPOLL_CLOEXEC);
        epoll_event ev{};
        ev.events = EPOLLIN;
        ::epoll_ctl(ep, EPOLL_CTL_ADD, slave, &ev);
        while (read_at.size() < n) {
            epoll_event out{};
            if (::epoll_wait(ep, &out, 1, 100) <= 0) {
                if (!writing.load()) {
                    break;
                }
                continue;
            }
            char c = 0;
            if (::read(slave, &c, 1) == 1) {
                read_at.push_back(now_ns());
            }
        }
        ::close(ep);
    });
    for (std::size_t i = 0; i < n; ++i) {
        std::this_thread::sleep_for(pause);
        sent[i] = now_ns();
        if (::write(master, "x", 1) != 1) {
            break;
        }
    }
    writing.store(false);
    reader.join();
    std::vector<double> samples;
    for (std::size_t i = 0; i < read_at.size(); ++i) {
        samples.push_back(us(read_at[i] - sent[i]));
    }
    ::close(master);
    ::close(slave);
    if (samples.size() < n) {
        throw Failure(fmt::format("pty hop: {} of {} bytes came through", samples.size(), n));
    }
    return samples;
}

std::vector<double> iceoryx_hop(std::size_t n, const fs::path& dir) {
    wait_for_no_roudi();
    const int roudi = spawn({"/usr/bin/iox-roudi"}, dir / "roudi.log");
    const auto stop_roudi = [&] {
        ::kill(roudi, SIGTERM);
        (void)wait_exit(roudi, 10s);
        (void)test::wait_until([] { return roudi_gone(); }, 5s);
    };
    if (!test::wait_until(roudi_answers, 10s)) {
        stop_roudi();
        throw Failure("iox-roudi did not come up: " + slurp(dir / "roudi.log.err"));
    }
    const int sub = spawn({BENCH_IOX_FLOOR_PATH, "sub", std::to_string(n)}, dir / "sub.out");
    const int pub = spawn({BENCH_IOX_FLOOR_PATH, "pub", std::to_string(n), "3000"}, dir / "pub.out");
    const int sub_status = wait_exit(sub, std::chrono::seconds(60 + n / 100));
    (void)wait_exit(pub, 30s);
    stop_roudi();
    if (sub_status != 0) {
        throw Failure("bench_iox_floor sub failed: " + slurp(dir / "sub.out.err"));
    }
    std::vector<double> samples;
    for (const auto& row : numbers(slurp(dir / "sub.out"))) {
        samples.push_back(us(row.at(0)));
    }
    return samples;
}

// cyclictest's histogram: one line per microsecond, "LATENCY COUNT"; latencies past its end
// are counted as overflows and taken here at the maximum it reports.
std::vector<double> cyclictest(std::size_t n, bool loaded, const fs::path& dir) {
    const fs::path hist = dir / (loaded ? "loaded.hist" : "idle.hist");
    std::optional<test::Child> stress;
    if (loaded) {
        stress.emplace(std::vector<std::string>{"/usr/bin/stress-ng", "--cpu", "0", "--timeout",
                                                std::to_string(n / 1000 + 60) + "s", "--quiet"});
        std::this_thread::sleep_for(500ms);
    }
    const int pid =
        spawn({"/usr/bin/cyclictest", "--mlockall", "--priority=80", "--interval=1000", "--loops=" + std::to_string(n),
               "--quiet", "--histogram=5000", "--histfile=" + hist.string(), "--threads=1"},
              dir / "cyclictest.out");
    const int status = wait_exit(pid, std::chrono::seconds(60 + n / 500));
    if (stress) {
        stress->stop();
    }
    if (status != 0) {
        throw Failure(fmt::format("cyclictest failed ({}): {}", status, slurp(dir / "cyclictest.out.err")));
    }
    std::vector<double> samples;
    std::istringstream in(slurp(hist));
    std::string line;
    double max = 0;
    std::size_t overflows = 0;
    while (std::getline(in, line)) {
        if (line.rfind("# Max Latencies:", 0) == 0) {
            max = std::atof(line.c_str() + 16);
        } else if (line.rfind("# Histogram Overflows:", 0) == 0) {
            overflows = static_cast<std::size_t>(std::atol(line.c_str() + 22));
        } else if (!line.empty() && line[0] != '#') {
            std::istringstream l(line);
            long latency = 0;
            long count = 0;
            if (l >> latency >> count) {
                samples.insert(samples.end(), static_cast<std::size_t>(count), static_cast<double>(latency));
            }
        }
    }
    samples.insert(samples.end(), overflows, max);
    return samples;
}

}  // namespace

void floors(const Options& o, std::vector<Row>& rows) {
    const std::size_t n = o.samples();
    const fs::path dir = fresh_dir("floors");
    note("floors: a pty hop, an iceoryx hop, cyclictest idle and under stress-ng");
    const auto add = [&](const std::string& what, const std::vector<double>& samples, const std::string& notes) {
        rows.push_back(samples_row("0", what, samples, notes));
    };
    // On a virtual machine the wake-up of a thread costs more the longer its CPU was idle
    // (the host stops polling a halted virtual CPU after a while): a reply comes a few hundred
    // microseconds after the request, a client's request onto an idle line.
    add("floor: pty hop, a byte written to a pty → a thread in epoll_wait on the other side reads it, 300 µs apart",
        pty_hop(n, 300us),
        "the kernel's pty worker and one wake-up, as a reply reaches a waiting master: under "
        "items 2 and 5");
    add("floor: pty hop, the same 3 ms apart", pty_hop(n, 3ms),
        "as a request reaches a drive on a quiet line: under item 1");
    add("floor: iceoryx 2.0 alone, a publish of a snapshot-sized sample → a Listener callback in another process",
        iceoryx_hop(n, dir), "bench_iox_floor on iox-roudi, every 3 ms: under items 1 and 2");
    add("floor: cyclictest (rt-tests), SCHED_FIFO 80, 1 ms timer, idle machine", cyclictest(n, false, dir),
        "how late a real-time thread's timer wake-up comes: under items 5 and 6");
    add("floor: cyclictest (rt-tests), SCHED_FIFO 80, 1 ms timer, under stress-ng --cpu 0", cyclictest(n, true, dir),
        "the same with every core loaded: under item 6");
}

}  // namespace drivebus::bench
