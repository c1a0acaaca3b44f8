// SPDX-License-Identifier: Apache-2.0
// Item 9 of docs/performance.md: Modbus TCP clients through drivebus-gateway, side by side with
// mbusd (a TCP -> RTU gateway that passes each request to the line) on the same simulator and
// line, 19200 8N1, one Altivar 58 at address 1.
//
//   bench_gateway [--smoke] [--seconds S] [--clients N] [--markdown FILE]
//
// N (16) libmodbus TCP clients, each on its own connection and thread, read one register back to
// back for S seconds (10): first W450, which drivebusd polls (every 2 s; max_age 3 s), then W453,
// which it does not, then W453 again while stress-ng loads every core. For each: transactions per second, p50/p99 of a
// read, and on the line the requests that started less than t3.5 after the simulator's last byte (its own count). mbusd
// is the `mbusd` found on PATH (mbusd 0.5 is not packaged by Debian: build it from its public source); without one the
// rows say so. It runs with its default 100 ms pause between requests, then with -R 1.
//
// --smoke: 1.5 s per phase; it checks that the benchmark works and asserts nothing about speed.
// Exit status: 0, or 1 when a run could not be made.
#include <arpa/inet.h>
#include <modbus.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <regex>
#include <thread>

#include "suite_tools.hpp"

using namespace drivebus;
using namespace drivebus::bench;
using namespace std::chrono_literals;

namespace {

// 19200 8N1: a character is 10 bits.
constexpr double kCharacterUs = 1e6 * 10.0 / 19200.0;
constexpr double kT35Us = 3.5 * kCharacterUs;
constexpr double kTurnaroundUs = 1000.0;  // the simulator's --turnaround
// FC03 of one register: an 8-byte request and a 7-byte reply, each followed by t3.5, and the
// drive's turnaround: the most transactions a line that keeps every silence can carry.
constexpr double kCeiling = 1e6 / ((8 + 7) * kCharacterUs + 2 * kT35Us + kTurnaroundUs);
constexpr int kPolled = 450;    // W450
constexpr int kUnpolled = 453;  // W453

struct Phase {
    double rate = 0;
    std::vector<double> latencies_us;
    std::uint64_t failures = 0;
    std::uint64_t line_requests = 0;
    std::uint64_t violations = 0;
};

struct Silences {
    std::uint64_t count = 0;
    std::uint64_t shorts = 0;
};

Silences silences(test::SimProcess& sim) {
    const auto s = sim.command("silences");
    return {std::stoull(field(s, "count")), std::stoull(field(s, "short"))};
}

// `clients` threads, each its own libmodbus TCP connection, reading `reg` back to back.
Phase run_clients(int port, int clients, int reg, double seconds, test::SimProcess& sim) {
    Phase phase;
    std::mutex mutex;
    std::atomic<bool> stop{false};
    std::atomic<int> connected{0};
    std::atomic<bool> go{false};
    std::vector<std::thread> threads;
    std::vector<std::string> errors;
    for (int i = 0; i < clients; ++i) {
        threads.emplace_back([&] {
            modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
            if (ctx != nullptr) {
                modbus_set_response_timeout(ctx, 10, 0);  // also the connect's: mbusd accepts between requests
            }
            if (ctx == nullptr || modbus_connect(ctx) != 0) {
                std::lock_guard lock(mutex);
                errors.emplace_back(modbus_strerror(errno));
                ++connected;
                return;
            }
            modbus_set_slave(ctx, 1);
            ++connected;
            while (!go) {
                std::this_thread::yield();
            }
            std::vector<double> mine;
            std::uint64_t failed = 0;
            std::uint16_t value = 0;
            while (!stop) {
                const auto t0 = now_ns();
                if (modbus_read_registers(ctx, reg, 1, &value) == 1) {
                    mine.push_back(us(now_ns() - t0));
                } else {
                    ++failed;
                }
            }
            modbus_close(ctx);
            modbus_free(ctx);
            std::lock_guard lock(mutex);
            phase.latencies_us.insert(phase.latencies_us.end(), mine.begin(), mine.end());
            phase.failures += failed;
        });
    }
    while (connected < clients) {
        std::this_thread::yield();
    }
    const auto before = silences(sim);
    const auto t0 = now_ns();
    go = true;
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    stop = true;
    // The answers already asked for still come: counted until the last client has its own.
    for (auto& t : threads) {
        t.join();
    }
    const auto t1 = now_ns();
    const auto after = silences(sim);
    if (!errors.empty()) {
        throw Failure("a TCP client could not connect: " + errors.front());
    }
    phase.rate = static_cast<double>(phase.latencies_us.size()) * 1e9 / static_cast<double>(t1 - t0);
    phase.line_requests = after.count - before.count;
    phase.violations = after.shorts - before.shorts;
    return phase;
}

std::vector<std::string> sim_args() {
    return {"--baud", "19200", "--parity", "none", "--turnaround", "1ms", "--realtime", "90", "--drive", "1:atv58"};
}

// A child process, stopped (SIGTERM, then waited for) when it goes.
class Process {
public:
    Process(const std::vector<std::string>& argv, const fs::path& out) : out_(out), pid_(spawn(argv, out)) {}
    ~Process() {
        ::kill(pid_, SIGTERM);
        (void)wait_exit(pid_, 10s);
    }
    Process(const Process&) = delete;
    Process& operator=(const Process&) = delete;
    Process(Process&&) = delete;
    Process& operator=(Process&&) = delete;
    [[nodiscard]] std::string output() const { return slurp(out_) + slurp(out_.string() + ".err"); }

private:
    fs::path out_;
    int pid_;
};

std::string describe(const Phase& p) {
    return fmt::format(
        "{:.1f} transactions/s; {} failed; on the line: requests less than t3.5 after the "
        "simulator's last byte **{}** of {}",
        p.rate, p.failures, p.violations, p.line_requests);
}

void drivebus_runs(double seconds, int clients, std::vector<Row>& rows, const std::optional<double>& mbusd_rate) {
    const fs::path dir = fresh_dir("gateway");
    test::SimProcess sim(sim_args(), dir);
    wait_for_no_roudi();
    const fs::path config = dir / "drivebusd.toml";
    // As deployed: the bus thread at SCHED_FIFO (drivebusd's default), so that the loaded run measures
    // drivebus rather than a bus thread the scheduler shares out with stress-ng.
    std::ofstream(config) << "[realtime]\nmode = \"best-effort\"\nlock_memory = false\n[ipc]\nroudi = \"embedded\"\n"
                          << "[[bus]]\nname = \"bench\"\ndevice = \"" << sim.link().string()
                          << "\"\nbaud = 19200\nparity = \"none\"\ndirection = \"none\"\n"
                             "response_timeout = \"100ms\"\nretries = 2\n"
                             "  [[bus.drive]]\n  name = \"d1\"\n  address = 1\n  profile = \"atv58\"\n"
                             "    [[bus.drive.poll]]\n    registers = [\"W450\"]\n    period = \"2s\"\n";
    // Destroyed after drivebusd: the next user of iceoryx (a test, the other benchmark) starts
    // only once this drivebusd's RouDi has let its lock go.
    struct AfterDaemon {
        AfterDaemon() = default;
        AfterDaemon(const AfterDaemon&) = delete;
        AfterDaemon& operator=(const AfterDaemon&) = delete;
        AfterDaemon(AfterDaemon&&) = delete;
        AfterDaemon& operator=(AfterDaemon&&) = delete;
        ~AfterDaemon() {
            (void)test::wait_until([] { return roudi_gone(); }, 10s);
        }
    } after_daemon;
    Process daemon({DRIVEBUSD_PATH, "--config", config.string()}, dir / "drivebusd.log");
    if (!test::wait_until([&] { return roudi_answers() && daemon.output().find("running:") != std::string::npos; },
                          20s)) {
        throw Failure("drivebusd did not come up: " + daemon.output());
    }
    const fs::path gconfig = dir / "gateway.toml";
    std::ofstream(gconfig) << "[gateway]\nlisten = \"127.0.0.1:0\"\nmax_age = \"3s\"\nmax_connections = 64\n";
    Process gateway({GATEWAY_PATH, "--config", gconfig.string()}, dir / "gateway.log");
    int port = 0;
    const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
    if (!test::wait_until(
            [&] {
                std::smatch m;
                const auto out = gateway.output();
                if (std::regex_search(out, m, listening)) {
                    port = std::stoi(m[1]);
                }
                return port != 0;
            },
            20s)) {
        throw Failure("drivebus-gateway did not come up: " + gateway.output());
    }
    std::this_thread::sleep_for(2500ms);  // the first poll of W450 is in the snapshot

    note("drivebus-gateway: polled register");
    const auto polled = run_clients(port, clients, kPolled, seconds, sim);
    Row a = samples_row("9", fmt::format("Modbus TCP, {} clients, a polled register: drivebus-gateway", clients),
                        polled.latencies_us, describe(polled));
    a.target = "≥ 100 × mbusd's default rate, 0 violations";
    if (mbusd_rate && *mbusd_rate > 0) {
        const double ratio = polled.rate / *mbusd_rate;
        a.notes += fmt::format("; **{:.0f}×** mbusd's default rate", ratio);
        a.met = ratio >= 100.0 && polled.violations == 0 && polled.failures == 0;
    } else {
        a.notes += "; no mbusd on PATH to compare with";
    }
    rows.push_back(a);

    note("drivebus-gateway: unpolled register");
    const auto unpolled = run_clients(port, clients, kUnpolled, seconds, sim);
    Row b = samples_row("9", fmt::format("Modbus TCP, {} clients, an unpolled register: drivebus-gateway", clients),
                        unpolled.latencies_us, describe(unpolled));
    b.notes += fmt::format(
        "; **{:.3f}** of the line's compliant ceiling ({:.1f}/s, 1 ms turnaround; drivebusd also "
        "polls W450 every 2 s)",
        unpolled.rate / kCeiling, kCeiling);
    b.target = "≥ 0.95 × ceiling, 0 violations";
    b.met = unpolled.rate / kCeiling >= 0.95 && unpolled.violations == 0 && unpolled.failures == 0;
    rows.push_back(b);

    const unsigned cores = std::max(1U, std::thread::hardware_concurrency());
    note("drivebus-gateway: unpolled register under stress-ng");
    Process stress({"/usr/bin/stress-ng", "--cpu", std::to_string(cores), "--io", "1", "--vm", "1", "--timeout",
                    std::to_string(static_cast<int>(seconds) + 30) + "s", "--quiet"},
                   dir / "stress.log");
    std::this_thread::sleep_for(500ms);  // every stressor running
    const auto loaded = run_clients(port, clients, kUnpolled, seconds, sim);
    Row c = samples_row("9", fmt::format("the same under stress-ng --cpu {} --io 1 --vm 1: drivebus-gateway", cores),
                        loaded.latencies_us, describe(loaded));
    c.notes += fmt::format("; **{:.3f}** of the ceiling", loaded.rate / kCeiling);
    c.target = "≥ 0.9 × ceiling, 0 violations";
    c.met = loaded.rate / kCeiling >= 0.9 && loaded.violations == 0;
    rows.push_back(c);
}

std::optional<std::string> find_mbusd() {
    const char* path = std::getenv("PATH");
    std::string paths = path != nullptr ? path : "/usr/local/bin:/usr/bin:/bin";
    std::size_t at = 0;
    while (at <= paths.size()) {
        const auto colon = paths.find(':', at);
        const std::string dir = paths.substr(at, colon == std::string::npos ? std::string::npos : colon - at);
        const fs::path candidate = fs::path(dir.empty() ? "." : dir) / "mbusd";
        if (::access(candidate.c_str(), X_OK) == 0) {
            return candidate.string();
        }
        if (colon == std::string::npos) {
            break;
        }
        at = colon + 1;
    }
    return std::nullopt;
}

int free_port() {
    // The kernel's choice for a socket bound to port 0, released at once: mbusd takes no port 0.
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t length = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &length);
    ::close(fd);
    return ntohs(a.sin_port);
}

// mbusd on the simulator's pty with `pause_ms` between requests; both phases unless `one`.
std::optional<double> mbusd_runs(const std::string& mbusd, int pause_ms, double seconds, int clients,
                                 std::vector<Row>& rows, bool both) {
    const fs::path dir = fresh_dir("mbusd");
    test::SimProcess sim(sim_args(), dir);
    const int port = free_port();
    Process server({mbusd, "-d",
                    "-L",  "-",
                    "-v",  "0",
                    "-p",  sim.link().string(),
                    "-s",  "19200",
                    "-m",  "8N1",
                    "-A",  "127.0.0.1",
                    "-P",  std::to_string(port),
                    "-R",  std::to_string(pause_ms),
                    "-C",  "64"},
                   dir / "mbusd.log");
    if (!test::wait_until(
            [&] {
                modbus_t* probe = modbus_new_tcp("127.0.0.1", port);
                const bool up = probe != nullptr && modbus_connect(probe) == 0;
                if (probe != nullptr) {
                    modbus_close(probe);
                    modbus_free(probe);
                }
                return up;
            },
            10s)) {
        throw Failure("mbusd did not come up: " + server.output());
    }
    std::optional<double> first;
    for (const int reg : both ? std::vector<int>{kPolled, kUnpolled} : std::vector<int>{kUnpolled}) {
        note(fmt::format("mbusd -R {}: W{}", pause_ms, reg));
        const auto p = run_clients(port, clients, reg, seconds, sim);
        Row r = samples_row("9",
                            fmt::format("Modbus TCP, {} clients, {} register: mbusd -R {}{}", clients,
                                        reg == kPolled ? "the polled" : "the unpolled", pause_ms,
                                        pause_ms == 100 ? " (its default)" : ""),
                            p.latencies_us, describe(p));
        r.notes += fmt::format("; {:.3f} of the ceiling (mbusd reads the line for every request)", p.rate / kCeiling);
        rows.push_back(r);
        if (!first) {
            first = p.rate;
        }
    }
    return first;
}

}  // namespace

int main(int argc, char** argv) {
    bool smoke = false;
    double seconds = 10.0;
    int clients = 16;
    std::string markdown;
    for (int i = 1; i < argc; ++i) {
        const std::string key = argv[i];
        if (key == "--smoke") {
            smoke = true;
            seconds = 1.5;
        } else if (key == "--seconds" && i + 1 < argc) {
            seconds = std::atof(argv[++i]);
        } else if (key == "--clients" && i + 1 < argc) {
            clients = std::max(1, std::atoi(argv[++i]));
        } else if (key == "--markdown" && i + 1 < argc) {
            markdown = argv[++i];
        } else {
            std::fprintf(stderr, "usage: bench_gateway [--smoke] [--seconds S] [--clients N] [--markdown FILE]\n");
            return 2;
        }
    }
    ::signal(SIGPIPE, SIG_IGN);
    std::vector<Row> rows;
    int failures = 0;
    std::optional<double> mbusd_rate;
    const auto mbusd = find_mbusd();
    try {
        if (mbusd) {
            mbusd_rate = mbusd_runs(*mbusd, 100, seconds, clients, rows, true);
            (void)mbusd_runs(*mbusd, 1, seconds, clients, rows, false);
        } else {
            note("no mbusd on PATH: drivebus-gateway alone (mbusd 0.5 is built from its public source)");
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench: mbusd failed: %s\n", e.what());
        ++failures;
    }
    try {
        drivebus_runs(seconds, clients, rows, mbusd_rate);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench: drivebus-gateway failed: %s\n", e.what());
        ++failures;
    }
    if (smoke) {
        for (auto& r : rows) {
            r.met.reset();  // a smoke run is too short to judge
        }
    }
    const std::string text = table(rows);
    std::fputs(text.c_str(), stdout);
    if (!markdown.empty()) {
        std::ofstream(markdown) << text;
    }
    return failures == 0 ? 0 : 1;
}
