// SPDX-License-Identifier: Apache-2.0
// The performance suite of docs/performance.md: drivebus measured as its users would meet it,
// on pty loopback with drivebus-sim, and side by side with libmodbus. One table.
//
//   bench_suite [--smoke] [--samples N] [--only 1,2,...] [--markdown FILE]
//
//   0  floors: a pty hop, an iceoryx hop and cyclictest, idle and under stress-ng, with no
//      drivebus code on the path
//   1  client -> wire: a client's write to the first request byte the simulator reads (bus idle)
//   2  wire -> client: the simulator writing a reply's last byte to a subscriber holding the
//      snapshot it produced
//   3  round trip: a client's read through drivebusd, and libmodbus doing the same read on the
//      same pty against the same simulator, in alternating blocks
//   4  bus efficiency: transactions per second against the spec-compliant maximum, at 9600,
//      19200 and 115200 (8N1 and 8E1) with 1, 8 and 31 drives; libmodbus in a tight loop too
//   5  the silence left before each request beyond t3.5, at 19200 and 115200
//   6  cyclic polling period jitter while stress-ng loads every core, with SCHED_FIFO and without
//   7  drivebusd's CPU share and peak anonymous RSS polling 31 drives at 19200 with 16 clients
//   8  the wire rules under load: 4 drives polled back to back at 19200 and 115200, quiet and
//      under stress-ng, counted on the simulator's side (requests less than t3.5 after its last
//      byte) and the master's (foreign frames, CRC and gap errors, held and late replies)
//
// Items 1-3 and 7 run drivebusd (with its RouDi: one per machine, so the suite waits while
// another one answers on /tmp/roudi). Items 4-6 run the bus thread drivebusd runs (BusLoop)
// inside this process, without shared memory. The simulator times its side with --tx-log and
// --rx-log (CLOCK_MONOTONIC, like everything here).
//
// --smoke runs every item with a few hundred samples: it checks that the benchmarks work and
// asserts nothing about speed. Exit status: 0, or 1 when a benchmark could not run.
#include <fcntl.h>
#include <modbus.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "floors.hpp"
#include "sim_process.hpp"
#include "stats.hpp"
#include "suite_tools.hpp"

namespace fs = std::filesystem;
using namespace drivebus;
using namespace drivebus::bench;
using namespace std::chrono_literals;

namespace {

std::string run_client(const std::vector<std::string>& args, const fs::path& dir, std::chrono::seconds timeout) {
    std::vector<std::string> argv{BENCH_CLIENT_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    const fs::path out = dir / fmt::format("client-{}.out", now_ns());
    const int status = wait_exit(spawn(argv, out), timeout);
    if (status != 0) {
        throw Failure(fmt::format("bench_client {} failed ({}): {}", args.at(1), status, slurp(out.string() + ".err")));
    }
    return slurp(out);
}

// ---- the line ----

struct Line {
    std::uint32_t baud = 19200;
    rtu::Parity parity = rtu::Parity::None;
    [[nodiscard]] rtu::LineFormat format() const { return {baud, 8, parity, 1}; }
    [[nodiscard]] std::string name() const {
        return fmt::format("{} 8{}1", baud, parity == rtu::Parity::None ? 'N' : 'E');
    }
    [[nodiscard]] std::string parity_word() const { return parity == rtu::Parity::None ? "none" : "even"; }
    [[nodiscard]] char parity_char() const { return parity == rtu::Parity::None ? 'N' : 'E'; }
    [[nodiscard]] double character_us() const {
        return 1e6 * (parity == rtu::Parity::None ? 10.0 : 11.0) / static_cast<double>(baud);
    }
    [[nodiscard]] double t35_us() const { return baud <= 19200 ? 3.5 * character_us() : 1750.0; }
    // The spec-compliant time of one transaction: request on the wire, t3.5 for the drive to
    // see its end, the drive's turnaround, the reply on the wire, t3.5 before the next request.
    [[nodiscard]] double transaction_us(int request, int reply, double turnaround_us) const {
        return (request + reply) * character_us() + 2 * t35_us() + turnaround_us;
    }
    [[nodiscard]] std::int64_t t35_ns() const { return std::llround(t35_us() * 1000.0); }
};

// Paced, the simulator runs SCHED_FIFO: it is the instrument, and its own slips (a reply
// character late by more than t1.5 breaks the reply) would otherwise be charged to the master.
std::vector<std::string> sim_args(const Line& line, int drives, const std::string& turnaround, bool paced) {
    std::vector<std::string> args{"--baud",  std::to_string(line.baud), "--parity", line.parity_word(), "--turnaround",
                                  turnaround};
    if (paced) {
        args.insert(args.end(), {"--realtime", "90"});
    }
    for (int a = 1; a <= drives; ++a) {
        args.insert(args.end(), {"--drive", std::to_string(a) + ":atv58"});
    }
    if (!paced) {
        args.emplace_back("--no-pace");
    }
    return args;
}

// ---- drivebusd ----

std::string drive_tables(int drives, const std::string& registers, const std::string& period) {
    std::string out;
    for (int a = 1; a <= drives; ++a) {
        out += fmt::format("  [[bus.drive]]\n  name = \"d{}\"\n  address = {}\n  profile = \"atv58\"\n", a, a);
        if (!period.empty()) {
            out +=
                fmt::format("    [[bus.drive.poll]]\n    registers = [{}]\n    period = \"{}\"\n", registers, period);
        }
    }
    return out;
}

class Daemon {
public:
    // `realtime`: the [realtime] table's keys; normal scheduling and no locked memory unless given.
    Daemon(const fs::path& dir, const std::string& bus, const fs::path& device, const Line& line,
           const std::string& drives, const std::string& realtime = "mode = \"off\"\nlock_memory = false\n")
        : log_(dir / "drivebusd.log") {
        const fs::path config = dir / "drivebusd.toml";
        std::ofstream(config) << "[realtime]\n"
                              << realtime << "[ipc]\nroudi = \"embedded\"\n"
                              << "[[bus]]\nname = \"" << bus << "\"\ndevice = \"" << device.string()
                              << "\"\nbaud = " << line.baud << "\nparity = \"" << line.parity_word()
                              << "\"\ndirection = \"none\"\nresponse_timeout = \"100ms\"\nretries = 2\n"
                              << drives;
        for (int attempt = 0;; ++attempt) {
            wait_for_no_roudi();
            pid_ = spawn({DRIVEBUSD_PATH, "--config", config.string()}, log_);
            if (test::wait_until([&] { return roudi_answers() && output().find("running:") != std::string::npos; },
                                 10s)) {
                break;
            }
            const std::string out = output();
            stop();
            if (out.find(".toml") != std::string::npos) {
                throw Failure("drivebusd refused its configuration: " + out);
            }
            if (attempt == 2) {
                throw Failure("drivebusd did not come up: " + out);
            }
            note("drivebusd did not come up (another RouDi?); trying again");
        }
    }
    ~Daemon() { stop(); }
    Daemon(const Daemon&) = delete;
    Daemon& operator=(const Daemon&) = delete;
    Daemon(Daemon&&) = delete;
    Daemon& operator=(Daemon&&) = delete;

    void stop() {
        if (pid_ > 0) {
            ::kill(pid_, SIGTERM);
            (void)wait_exit(pid_, 10s);
            pid_ = -1;
            // Its RouDi goes with it, before anything else starts one.
            (void)test::wait_until([] { return roudi_gone(); }, 5s);
        }
    }
    [[nodiscard]] int pid() const noexcept { return pid_; }
    [[nodiscard]] std::string output() const { return slurp(log_) + slurp(log_.string() + ".err"); }

private:
    fs::path log_;
    int pid_ = -1;
};

// ---- libmodbus ----

class Libmodbus {
public:
    Libmodbus(const fs::path& device, const Line& line) {
        ctx_ = modbus_new_rtu(device.c_str(), static_cast<int>(line.baud), line.parity_char(), 8, 1);
        if (ctx_ == nullptr || modbus_connect(ctx_) != 0) {
            throw Failure("libmodbus: cannot open " + device.string());
        }
        modbus_set_response_timeout(ctx_, 0, 500000);
    }
    ~Libmodbus() {
        modbus_close(ctx_);
        modbus_free(ctx_);
    }
    Libmodbus(const Libmodbus&) = delete;
    Libmodbus& operator=(const Libmodbus&) = delete;
    Libmodbus(Libmodbus&&) = delete;
    Libmodbus& operator=(Libmodbus&&) = delete;

    bool read(int address, int reg, int count) {
        std::uint16_t values[32];
        modbus_set_slave(ctx_, address);
        return modbus_read_registers(ctx_, reg, count, values) == count;
    }

private:
    modbus_t* ctx_ = nullptr;
};

// ---- items 1 to 3: latency through drivebusd, and libmodbus's direct read ----

void latency(const Options& o, std::vector<Row>& rows) {
    const Line line{19200, rtu::Parity::None};  // what the Altivar 58 speaks
    const std::size_t n = o.samples();
    constexpr auto kPause = "3000";  // µs after each read (item 3): both masters start from a quiet line
    // Item 1's bus must be idle by the wire's clock, not only by the unpaced simulator's: the
    // reply comes back long before the request could have left a real wire (8 characters,
    // 4.2 ms at 19200), and drivebusd keeps the line busy until then plus t3.5.
    constexpr auto kIdlePause = "8000";
    const fs::path dir = fresh_dir("latency");

    if (o.runs(2)) {
        note("wire -> client: drivebusd polling one drive as fast as it may, unpaced simulator");
        std::vector<bench::Summary> out;
        const fs::path simdir = dir / "sim2";
        fs::create_directories(simdir);
        auto args = sim_args(line, 1, "100us", false);
        args.insert(args.end(), {"--tx-log", (simdir / "tx.log").string()});
        std::string text;
        {
            test::SimProcess sim(args, simdir);
            Daemon daemon(dir, "bench2", sim.link(), line,
                          drive_tables(1, "\"W450\", \"W451\", \"W452\", \"W453\"", "1ms"));
            text = run_client({"bench2", "snapshots", "d1", std::to_string(n + 20)}, dir, 600s);
            daemon.stop();
            sim.stop();
        }
        const auto tx = read_events(simdir / "tx.log");
        std::vector<double> samples;
        std::vector<double> pty_part;
        std::vector<double> drivebus_part;
        std::vector<double> daemon_part;
        std::size_t unmatched = 0;
        const auto got = numbers(text);
        for (std::size_t i = 20; i < got.size(); ++i) {  // the first ones: history and start-up
            const std::int64_t recv = got[i].at(0);
            const std::int64_t reply = got[i].at(1);
            auto it = std::ranges::lower_bound(tx, reply, {}, &Event::ns);
            std::optional<std::int64_t> best;
            for (auto c : {it, it == tx.begin() ? it : std::prev(it)}) {
                if (c != tx.end() && (!best || std::llabs(c->ns - reply) < std::llabs(*best - reply))) {
                    best = c->ns;
                }
            }
            if (!best || std::llabs(*best - reply) > 500'000) {
                ++unmatched;
                continue;
            }
            samples.push_back(us(recv - *best));
            pty_part.push_back(us(reply - *best));
            drivebus_part.push_back(us(recv - reply));
            daemon_part.push_back(us(got[i].at(3) - reply));
        }
        Row r{"2", "wire → client: simulator writes a reply's last byte → subscriber holds the snapshot"};
        r.samples = samples.size();
        r.summary = bench::summarize(samples);
        r.notes = fmt::format("{} unpaced; on_snapshot callback{}", line.name(),
                              unmatched > 0 ? fmt::format(", {} unmatched", unmatched) : "");
        r.target = "p99 ≤ 50 µs";
        r.met = r.summary->p99 <= 50.0;
        rows.push_back(r);
        rows.push_back(samples_row(
            "2", "of which the pty: simulator writes the last byte → drivebusd's read() returns it", pty_part,
            "the reply's time in the snapshot is the moment drivebusd's read returned its last "
            "byte"));
        rows.push_back(samples_row("2", "of which drivebus: drivebusd's read() returns → subscriber holds the snapshot",
                                   drivebus_part,
                                   "framing, publication, iceoryx's notification, the client's Listener thread"));
        rows.push_back(samples_row("2", "of which drivebusd: read() returns → the snapshot is published", daemon_part,
                                   "the snapshot's published_ns, taken before the sample is loaned and published"));
    }

    if (!o.runs(1) && !o.runs(3)) {
        return;
    }
    note("client -> wire and round trips: drivebusd (idle bus) and libmodbus on one unpaced simulator");
    const fs::path simdir = dir / "sim13";
    fs::create_directories(simdir);
    auto args = sim_args(line, 1, "100us", false);
    args.insert(args.end(), {"--rx-log", (simdir / "rx.log").string()});
    const int blocks = o.smoke ? 1 : 5;
    const std::size_t per_block = n / static_cast<std::size_t>(blocks);
    std::vector<std::pair<std::int64_t, std::int64_t>> writes;
    std::vector<double> drivebus_rt;
    std::vector<double> libmodbus_rt;
    {
        test::SimProcess sim(args, simdir);
        for (int b = 0; b < blocks; ++b) {
            {
                Daemon daemon(dir, "bench13", sim.link(), line, drive_tables(1, "", ""));
                if (o.runs(1)) {
                    for (const auto& row : numbers(run_client(
                             {"bench13", "writes", "d1", "W401", std::to_string(per_block), kIdlePause}, dir, 600s))) {
                        writes.emplace_back(row.at(0), row.at(1));
                    }
                }
                if (o.runs(3)) {
                    for (const auto& row : numbers(run_client(
                             {"bench13", "reads", "d1", "W450", "4", std::to_string(per_block), kPause}, dir, 600s))) {
                        drivebus_rt.push_back(us(row.at(1) - row.at(0)));
                    }
                }
            }
            if (o.runs(3)) {
                Libmodbus mb(sim.link(), line);
                for (std::size_t i = 0; i < per_block; ++i) {
                    const std::int64_t sent = now_ns();
                    if (!mb.read(1, 0x01C2, 4)) {
                        throw Failure("libmodbus: a read failed");
                    }
                    libmodbus_rt.push_back(us(now_ns() - sent));
                    std::this_thread::sleep_for(std::chrono::microseconds(std::atoi(kPause)));
                }
            }
        }
        sim.stop();
    }
    if (o.runs(1)) {
        std::vector<Event> w;
        for (const auto& e : read_events(simdir / "rx.log")) {
            if (e.function == 6) {
                w.push_back(e);
            }
        }
        std::vector<double> samples;
        for (const auto& [sent, done] : writes) {
            auto it = std::ranges::lower_bound(w, sent, {}, &Event::ns);
            if (it != w.end() && it->ns <= done) {
                samples.push_back(us(it->ns - sent));
            }
        }
        Row r{"1", "client → wire: client's write() → simulator reads the request's first byte (bus idle)"};
        r.samples = samples.size();
        r.summary = bench::summarize(samples);
        r.notes = fmt::format("{} unpaced; write of W401 (control lease held); {} of {} matched", line.name(),
                              samples.size(), writes.size());
        r.target = "p99 ≤ 100 µs";
        r.met = r.summary->p99 <= 100.0;
        rows.push_back(r);
    }
    if (o.runs(3)) {
        const auto d = bench::summarize(drivebus_rt);
        const auto m = bench::summarize(libmodbus_rt);
        Row r{"3", "round trip: client's read of 4 registers through drivebusd"};
        r.samples = drivebus_rt.size();
        r.summary = d;
        r.notes = fmt::format(
            "{} unpaced (the simulator answers t3.5 + 100 µs after a request); {} alternating "
            "blocks; idle bus before each read",
            line.name(), blocks);
        const double ratio = d.p50 / m.p50;
        r.target = "p50 ≤ 1.25 × libmodbus";
        r.met = ratio <= 1.25;
        Row l{"3", "round trip: libmodbus modbus_read_registers() on the same pty"};
        l.samples = libmodbus_rt.size();
        l.summary = m;
        l.notes = fmt::format("drivebus / libmodbus at p50: **{:.3f}**, p99: {:.3f}", ratio, d.p99 / m.p99);
        rows.push_back(r);
        rows.push_back(l);
    }
}

// ---- items 4 to 6: the bus thread ----

config::BusConfig bus_config(const Line& line, const fs::path& device, int drives, std::vector<std::string> regs,
                             rtu::Duration period) {
    static const auto atv58 = test::load("atv58");
    config::BusConfig config = test::bus<config::BusConfig>(line.format());
    config.device = device;
    config.response_timeout = 100ms;
    for (int a = 1; a <= drives; ++a) {
        auto d = test::drive("d" + std::to_string(a), static_cast<std::uint8_t>(a), atv58);
        d.polls.push_back(test::poll(*atv58, regs, period));
        config.drives.push_back(d);
    }
    return config;
}

bus::LoopOptions loop_options(std::optional<int> fifo) {
    bus::LoopOptions options;
    if (fifo) {
        config::RealtimeConfig rt;
        rt.mode = config::RealtimeMode::Required;
        rt.priority = *fifo;
        options.realtime = rt;
    }
    return options;
}

void efficiency(const Options& o, std::vector<Row>& rows) {
    std::vector<std::pair<Line, int>> runs;
    for (const std::uint32_t baud : {9600U, 19200U, 115200U}) {
        for (const auto parity : {rtu::Parity::None, rtu::Parity::Even}) {
            for (const int drives : {1, 8, 31}) {
                if (!o.smoke || (baud == 19200 && drives != 8) ||
                    (baud == 115200 && drives == 1 && parity == rtu::Parity::None)) {
                    runs.emplace_back(Line{baud, parity}, drives);
                }
            }
        }
    }
    for (const auto& [line, drives] : runs) {
        const double seconds = o.smoke ? 1.0 : (line.baud == 9600 ? 6.0 : (line.baud == 19200 ? 4.0 : 3.0));
        const double max_rate = 1e6 / line.transaction_us(8, 13, 1000.0);
        note(fmt::format("bus efficiency {} x {} drives", line.name(), drives));
        // drivebus
        double rate = 0;
        std::uint64_t transactions = 0;
        std::uint64_t failures = 0;
        {
            test::SimProcess sim(sim_args(line, drives, "1ms", true));
            auto config = bus_config(line, sim.link(), drives, {"W450", "W451", "W452", "W453"}, 1ms);
            bus::BusLoop loop(config, {}, {});
            if (!loop.start()) {
                throw Failure("the bus loop did not start");
            }
            std::this_thread::sleep_for(500ms);
            const auto c0 = loop.status().counters;
            const auto t0 = now_ns();
            std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
            const auto c1 = loop.status().counters;
            const auto t1 = now_ns();
            loop.stop();
            transactions = c1.replies - c0.replies;
            failures = (c1.timeouts - c0.timeouts) + (c1.crc_errors - c0.crc_errors) + (c1.gap_errors - c0.gap_errors);
            if (failures > 0) {
                note(fmt::format("{} timeouts, {} CRC errors, {} gap errors, {} noise, {} malformed",
                                 c1.timeouts - c0.timeouts, c1.crc_errors - c0.crc_errors,
                                 c1.gap_errors - c0.gap_errors, c1.noise - c0.noise, c1.malformed - c0.malformed));
            }
            rate = static_cast<double>(transactions) * 1e9 / static_cast<double>(t1 - t0);
        }
        // libmodbus, in a tight loop over the same drives
        double mb_rate = 0;
        std::string silences;
        std::uint64_t mb_failures = 0;
        {
            test::SimProcess sim(sim_args(line, drives, "1ms", true));
            Libmodbus mb(sim.link(), line);
            std::uint64_t done = 0;
            const auto t0 = now_ns();
            const auto end = t0 + static_cast<std::int64_t>(seconds * 1e9);
            for (int a = 1; now_ns() < end; a = a % drives + 1) {
                if (mb.read(a, 0x01C2, 4)) {
                    ++done;
                } else {
                    ++mb_failures;
                }
            }
            mb_rate = static_cast<double>(done) * 1e9 / static_cast<double>(now_ns() - t0);
            silences = sim.command("silences");
        }
        const double ratio = rate / max_rate;
        Row r{"4", fmt::format("bus efficiency, {}, {} drive{}", line.name(), drives, drives > 1 ? "s" : "")};
        r.samples = transactions;
        const auto count = std::stoull(field(silences, "count"));
        const auto shorts = std::stoull(field(silences, "short"));
        r.notes = fmt::format(
            "drivebus {:.1f}/s of {:.1f}/s max = **{:.3f}**{}; libmodbus {:.1f}/s = {:.3f}, "
            "silence below t3.5 before {} of {} requests ({:.0f}%){}",
            rate, max_rate, ratio, failures > 0 ? fmt::format(" ({} failed)", failures) : "", mb_rate,
            mb_rate / max_rate, shorts, count,
            count > 0 ? 100.0 * static_cast<double>(shorts) / static_cast<double>(count) : 0.0,
            mb_failures > 0 ? fmt::format(" ({} failed)", mb_failures) : "");
        r.target = line.baud == 115200 ? "≥ 0.85" : "≥ 0.95";
        r.met = ratio >= (line.baud == 115200 ? 0.85 : 0.95);
        rows.push_back(r);
    }
}

// The bus thread as drivebusd runs it by default (SCHED_FIFO 50 where allowed), and with
// [realtime] send_spin.
void gap(const Options& o, std::vector<Row>& rows) {
    const std::size_t n = o.samples();
    for (const std::uint32_t baud : {19200U, 115200U}) {
        for (const rtu::Duration spin : {rtu::Duration{}, rtu::Duration{150us}}) {
            const Line line{baud, rtu::Parity::None};
            const std::string setting = spin.count() > 0 ? "send_spin 150 µs" : "default settings";
            note("gap beyond t3.5 at " + line.name() + ", " + setting);
            const fs::path dir = fresh_dir("gap");
            auto args = sim_args(line, 1, "100us", true);
            args.insert(args.end(), {"--tx-log", (dir / "tx.log").string(), "--rx-log", (dir / "rx.log").string()});
            std::vector<double> master_side;
            master_side.reserve(n + 1000);
            std::uint64_t retried = 0;
            {
                test::SimProcess sim(args, dir);
                auto config = bus_config(line, sim.link(), 1, {"W450"}, 1ms);
                auto options = loop_options(50);
                options.realtime->mode = config::RealtimeMode::BestEffort;
                options.send_spin = spin;
                options.on_written = [&](const bus::WriteTrace& w) {
                    master_side.push_back(us((w.writing - w.due).count()));
                };
                bus::BusLoop loop(config, {}, options);
                if (auto started = loop.start(); !started) {
                    throw Failure("the bus loop did not start: " + started.error());
                }
                const double seconds = static_cast<double>(n + 50) * line.transaction_us(8, 7, 100.0) * 1.1e-6 + 0.5;
                std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
                retried = loop.status().counters.retries;
                loop.stop();
                sim.stop();
            }
            const auto tx = read_events(dir / "tx.log");
            const auto rx = read_events(dir / "rx.log");
            std::vector<double> samples;
            std::size_t below = 0;
            for (const auto& e : rx) {
                auto it = std::ranges::lower_bound(tx, e.ns, {}, &Event::ns);
                if (it == tx.begin()) {
                    continue;
                }
                const std::int64_t beyond = e.ns - std::prev(it)->ns - line.t35_ns();
                below += beyond < 0 ? 1 : 0;
                samples.push_back(us(beyond));
            }
            for (auto* v : {&samples, &master_side}) {
                if (v->size() > 20) {
                    v->erase(v->begin(), v->begin() + 20);  // start-up
                }
            }
            Row m{"5", fmt::format("gap beyond t3.5 before each request, {}, {}: as drivebus keeps it", line.name(),
                                   setting)};
            m.samples = master_side.size();
            m.summary = bench::summarize(master_side);
            m.notes = "on the bus thread: the last character's read + t3.5 → the request's write() called";
            m.target = "p99 ≤ 100 µs";
            m.met = m.summary->p99 <= 100.0;
            rows.push_back(m);
            Row r{"5", "the same on the simulator's side of the pty"};
            r.samples = samples.size();
            r.summary = bench::summarize(samples);
            r.notes = fmt::format(
                "simulator's last reply byte written → next request's first byte read, minus t3.5 "
                "({:.0f} µs): two pty hops and the master's reaction; {} below t3.5; {} retries "
                "after broken replies",
                line.t35_us(), below, retried);
            rows.push_back(r);
        }
    }
}

// Each configuration's intervals between requests, as the bus thread wrote them and as the
// simulator read them: the deviation of each from the period, in µs.
struct JitterRun {
    std::vector<double> master_side;
    std::vector<double> sim_side;
    std::vector<double> late;     // write() called → when the request was due: the thread's own part
    std::size_t retries = 0;      // after replies the master saw broken
    std::vector<double> behind;   // each poll cycle's write() after the time its period made it due
    std::vector<double> on_time;  // the same, for the cycles whose line was free at that time
    std::size_t pushed = 0;       // cycles whose line was still busy at their time
};

JitterRun jitter_run(std::size_t n, std::optional<int> fifo, rtu::Duration spin) {
    const Line line{115200, rtu::Parity::None};
    constexpr auto kPeriod = 10ms;
    const double period_us = 10000.0;
    const fs::path dir = fresh_dir("jitter");
    auto args = sim_args(line, 1, "100us", true);
    args.insert(args.end(), {"--rx-log", (dir / "rx.log").string()});
    const double seconds = static_cast<double>(n + 20) * 0.010 + 0.5;
    std::vector<std::int64_t> writes;
    std::vector<double> late;
    std::vector<double> behind;
    std::vector<double> on_time;
    std::size_t retries = 0;
    std::size_t pushed = 0;
    writes.reserve(n + 1000);
    late.reserve(n + 1000);
    {
        test::Child stress({"/usr/bin/stress-ng", "--cpu", "0", "--timeout",
                            std::to_string(static_cast<int>(seconds) + 30) + "s", "--quiet"});
        std::this_thread::sleep_for(500ms);
        test::SimProcess sim(args, dir);
        auto config = bus_config(line, sim.link(), 1, {"W450"}, kPeriod);
        auto options = loop_options(fifo);
        options.send_spin = spin;
        // A retry is not a poll cycle: the intervals are between first attempts.
        options.on_written = [&](const bus::WriteTrace& w) {
            late.push_back(us((w.writing - w.due).count()));
            if (w.attempt > 1) {
                ++retries;
            } else if (w.scheduled) {
                writes.push_back(w.writing.time_since_epoch().count());
                behind.push_back(us((w.writing - *w.scheduled).count()));
                // A cycle whose line was still busy at its time (a retry ran over) says
                // nothing about the thread's timing.
                if (w.due <= *w.scheduled) {
                    on_time.push_back(us((w.writing - *w.scheduled).count()));
                } else {
                    ++pushed;
                }
            }
        };
        bus::BusLoop loop(config, {}, options);
        if (auto started = loop.start(); !started) {
            throw Failure("the bus loop did not start: " + started.error());
        }
        std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
        loop.stop();
        sim.stop();
        stress.stop();
    }
    JitterRun run;
    const auto rx = read_events(dir / "rx.log");
    for (std::size_t i = 11; i < rx.size(); ++i) {
        run.sim_side.push_back(std::abs(us(rx[i].ns - rx[i - 1].ns) - period_us));
    }
    for (std::size_t i = 11; i < writes.size(); ++i) {
        run.master_side.push_back(std::abs(us(writes[i] - writes[i - 1]) - period_us));
    }
    run.late.assign(late.begin() + std::min<std::ptrdiff_t>(11, std::ssize(late)), late.end());
    run.behind.assign(behind.begin() + std::min<std::ptrdiff_t>(11, std::ssize(behind)), behind.end());
    run.on_time.assign(on_time.begin() + std::min<std::ptrdiff_t>(11, std::ssize(on_time)), on_time.end());
    run.pushed = pushed;
    run.retries = retries;
    return run;
}

void jitter(const Options& o, std::vector<Row>& rows) {
    const std::size_t n = o.samples();
    struct Setting {
        std::string name;
        std::optional<int> fifo;
        rtu::Duration spin;
    };
    const std::vector<Setting> settings{{"SCHED_FIFO 80", 80, {}},
                                        {"SCHED_FIFO 80, send_spin 200 µs", 80, 200us},
                                        {"normal scheduling", std::nullopt, {}}};
    struct Result {
        bench::Summary on_time, behind, intervals, sim;
        std::size_t retries, pushed;
    };
    std::vector<Result> results;
    for (const auto& setting : settings) {
        note("polling period jitter under stress-ng, " + setting.name);
        const auto run = jitter_run(n, setting.fifo, setting.spin);
        results.push_back({bench::summarize(run.on_time), bench::summarize(run.behind),
                           bench::summarize(run.master_side), bench::summarize(run.sim_side), run.retries, run.pushed});
    }
    const auto& without = results.back();
    for (std::size_t i = 0; i < settings.size(); ++i) {
        const auto& [on_time, behind, intervals, sim, retries, pushed] = results[i];
        Row r{"6", "polling period jitter under stress-ng --cpu 0, " + settings[i].name};
        r.samples = on_time.count;
        r.summary = on_time;
        r.notes = fmt::format(
            "115200 8N1, period 10 ms: each poll cycle's write() after the time its period made it due, on the bus "
            "thread, for the cycles whose line was free then. {} cycles found the line still busy with a retry ({} "
            "retries after replies the master saw broken); with them: p99 {}, p99.9 {} µs. Intervals between cycles "
            "off the period: p99.9 {} µs; as the simulator (SCHED_FIFO 90) reads them, behind the pty's kernel worker, "
            "retries included: p99.9 {} µs",
            pushed, retries, cell(behind.p99), cell(behind.p999), cell(intervals.p999), cell(sim.p999));
        if (settings[i].fifo) {
            const double ratio = without.on_time.p999 / std::max(on_time.p999, 0.001);
            r.notes += fmt::format("; normal scheduling / this at p99.9: **{:.1f}×**", ratio);
            r.target = "p99.9 ≤ 200 µs, ≥ 10× lower than without";
            r.met = on_time.p999 <= 200.0 && ratio >= 10.0;
        }
        rows.push_back(r);
    }
}

// ---- item 8: the wire rules under load ----

struct WireRun {
    double rate = 0;  // replies per second
    std::uint64_t replies = 0;
    std::uint64_t requests = 0;    // as the simulator counted them (silences measured)
    std::uint64_t violations = 0;  // of which less than t3.5 after the simulator's last byte
    master::BusCounters counters;  // over the measured span
};

master::BusCounters minus(const master::BusCounters& a, const master::BusCounters& b) {
    master::BusCounters d = a;
    d.replies -= b.replies;
    d.foreign -= b.foreign;
    d.crc_errors -= b.crc_errors;
    d.gap_errors -= b.gap_errors;
    d.held_replies -= b.held_replies;
    d.late_replies -= b.late_replies;
    d.retries -= b.retries;
    d.timeouts -= b.timeouts;
    return d;
}

WireRun wire_run(const Line& line, double seconds, bool loaded) {
    std::optional<test::Child> stress;
    if (loaded) {
        stress.emplace(std::vector<std::string>{
            "/usr/bin/stress-ng", "--cpu", std::to_string(std::thread::hardware_concurrency()), "--io", "1", "--vm",
            "1", "--timeout", std::to_string(static_cast<int>(seconds) + 30) + "s", "--quiet"});
        std::this_thread::sleep_for(500ms);
    }
    WireRun run;
    test::SimProcess sim(sim_args(line, 4, "1ms", true));
    auto config = bus_config(line, sim.link(), 4, {"W450", "W451", "W452", "W453"}, 1ms);
    bus::BusLoop loop(config, {}, loop_options(50));
    if (auto started = loop.start(); !started) {
        throw Failure("the bus loop did not start: " + started.error());
    }
    std::this_thread::sleep_for(500ms);
    const auto c0 = loop.status().counters;
    const auto t0 = now_ns();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const auto c1 = loop.status().counters;
    const auto t1 = now_ns();
    loop.stop();
    const std::string silences = sim.command("silences");
    sim.stop();
    if (stress) {
        stress->stop();
    }
    run.counters = minus(c1, c0);
    run.replies = run.counters.replies;
    run.rate = static_cast<double>(run.replies) * 1e9 / static_cast<double>(t1 - t0);
    run.requests = std::stoull(field(silences, "count"));
    run.violations = std::stoull(field(silences, "short"));
    return run;
}

void wire_rules(const Options& o, std::vector<Row>& rows) {
    const double seconds = o.smoke ? 2.0 : 20.0;
    for (const std::uint32_t baud : {19200U, 115200U}) {
        const Line line{baud, rtu::Parity::None};
        double quiet_rate = 0;
        for (const bool loaded : {false, true}) {
            const std::string load =
                loaded ? fmt::format("stress-ng --cpu {} --io 1 --vm 1", std::thread::hardware_concurrency()) : "quiet";
            note(fmt::format("wire rules at {}, {}", line.name(), load));
            const WireRun run = wire_run(line, seconds, loaded);
            const auto& c = run.counters;
            const std::uint64_t errors = c.crc_errors + c.gap_errors;
            const double error_share =
                run.replies > 0 ? static_cast<double>(errors) / static_cast<double>(run.replies) : 1.0;
            Row r{"8", fmt::format("wire rules, {}, 4 drives back to back, {}", line.name(), load)};
            r.samples = run.replies;
            r.notes = fmt::format(
                "{:.1f} transactions/s; requests less than t3.5 after the simulator's last byte: **{}** of {}; "
                "foreign frames **{}**; CRC + gap errors **{}** ({:.2f}% of replies); held replies {}; late {}; "
                "retries {}; timeouts {}",
                run.rate, run.violations, run.requests, c.foreign, errors, 100.0 * error_share, c.held_replies,
                c.late_replies, c.retries, c.timeouts);
            r.met = run.violations == 0 && c.foreign == 0 && error_share <= 0.001;
            r.target = "0 violations, 0 foreign, errors ≤ 0.1%";
            if (loaded) {
                const double ratio = quiet_rate > 0 ? run.rate / quiet_rate : 0.0;
                r.notes += fmt::format("; loaded / quiet: **{:.3f}**", ratio);
                r.target += ", ≥ 0.9 × quiet";
                r.met = *r.met && ratio >= 0.9;
            } else {
                quiet_rate = run.rate;
            }
            rows.push_back(r);
        }
    }
}

// ---- item 7: cost ----

// The shipped real-time defaults. Under AddressSanitizer, memory locking would look through the
// sanitizer's terabytes of shadow memory, which is not the daemon's: the smoke run leaves it out.
#if defined(__SANITIZE_ADDRESS__)
constexpr const char* kCostRealtime = "mode = \"best-effort\"\nlock_memory = false\n";
#else
constexpr const char* kCostRealtime = "mode = \"best-effort\"\n";
#endif

struct ProcSample {
    double cpu_s = 0;
    long rss_anon_kb = 0;
    long hwm_kb = 0;
    long locked_kb = 0;  // VmLck
};

// utime + stime, in seconds, of a /proc stat file (a process's or a thread's).
double proc_sample_path(const fs::path& stat_file) {
    const std::string stat = slurp(stat_file);
    const auto close = stat.rfind(')');
    if (close == std::string::npos) {
        return 0;
    }
    std::istringstream in(stat.substr(close + 2));
    std::vector<std::string> f;
    std::string x;
    while (in >> x) {
        f.push_back(x);
    }
    if (f.size() <= 13) {  // fields 14 and 15 of stat: utime, stime (after pid and comm)
        return 0;
    }
    return static_cast<double>(std::stoll(f[11]) + std::stoll(f[12])) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

ProcSample proc_sample(int pid) {
    ProcSample s;
    s.cpu_s = proc_sample_path(fs::path("/proc") / std::to_string(pid) / "stat");
    std::istringstream status(slurp(fs::path("/proc") / std::to_string(pid) / "status"));
    std::string line;
    while (std::getline(status, line)) {
        if (line.rfind("RssAnon:", 0) == 0) {
            s.rss_anon_kb = std::atol(line.c_str() + 8);
        } else if (line.rfind("VmHWM:", 0) == 0) {
            s.hwm_kb = std::atol(line.c_str() + 6);
        } else if (line.rfind("VmLck:", 0) == 0) {
            s.locked_kb = std::atol(line.c_str() + 6);
        }
    }
    return s;
}

// CPU seconds of each of a process's threads, by name; iceoryx's RouDi threads (embedded in
// drivebusd by default) as one.
std::map<std::string, double> thread_cpu(int pid) {
    static const std::set<std::string> roudi{"PortIntr",     "ProcessIntr",     "MemPoolIntr",
                                             "Mon+Discover", "IPC-msg-process", "KeepAlive"};
    std::map<std::string, double> out;
    const fs::path tasks = fs::path("/proc") / std::to_string(pid) / "task";
    std::error_code ec;
    for (const auto& task : fs::directory_iterator(tasks, ec)) {
        std::string comm = slurp(task.path() / "comm");
        while (!comm.empty() && comm.back() == '\n') {
            comm.pop_back();
        }
        const auto cpu = proc_sample_path(task.path() / "stat");
        out[roudi.contains(comm) ? "RouDi" : comm] += cpu;
    }
    return out;
}

void cost_run(const Options& o, std::vector<Row>& rows, int clients) {
    const Line line{19200, rtu::Parity::None};
    const int drives = 31;
    const double seconds = o.smoke ? 3.0 : 30.0;
    note(fmt::format("cost: drivebusd polling 31 drives at 19200 with {} clients", clients));
    const fs::path dir = fresh_dir("cost");
    test::SimProcess sim(sim_args(line, drives, "1ms", true));
    // The shipped real-time defaults (best-effort SCHED_FIFO, memory locked), so that VmLck is
    // what a deployment locks.
    Daemon daemon(dir, "bench7", sim.link(), line,
                  drive_tables(drives, "\"W450\", \"W451\", \"W452\", \"W453\"", "1ms"), kCostRealtime);
    const int pid = daemon.pid();
    if (pid <= 0) {
        throw Failure("no pid in drivebusd's output: " + daemon.output());
    }
    std::vector<int> pids;
    for (int c = 0; c < clients; ++c) {
        pids.push_back(spawn({BENCH_CLIENT_PATH, "bench7", "watch", fmt::format("{}", seconds + 2.0)},
                             dir / fmt::format("watch-{}.out", c)));
    }
    std::this_thread::sleep_for(1500ms);  // connected and subscribed
    const auto s0 = proc_sample(pid);
    const auto threads0 = thread_cpu(pid);
    const auto r0 = std::stoull(field(sim.command("stats"), "requests"));
    const auto t0 = now_ns();
    long peak_anon = s0.rss_anon_kb;
    const auto end = t0 + static_cast<std::int64_t>(seconds * 1e9);
    while (now_ns() < end) {
        std::this_thread::sleep_for(100ms);
        peak_anon = std::max(peak_anon, proc_sample(pid).rss_anon_kb);
    }
    const auto s1 = proc_sample(pid);
    const auto threads1 = thread_cpu(pid);
    const auto r1 = std::stoull(field(sim.command("stats"), "requests"));
    const auto t1 = now_ns();
    std::uint64_t received = 0;
    int failed = 0;
    for (int c = 0; c < clients; ++c) {
        if (wait_exit(pids[static_cast<std::size_t>(c)], 30s) != 0) {
            ++failed;
            continue;
        }
        received += std::stoull("0" + slurp(dir / fmt::format("watch-{}.out", c)));
    }
    daemon.stop();
    if (failed > 0) {
        throw Failure(fmt::format("{} of the watching clients failed", failed));
    }
    const double wall = static_cast<double>(t1 - t0) / 1e9;
    const double share = 100.0 * (s1.cpu_s - s0.cpu_s) / wall;
    const double rate = static_cast<double>(r1 - r0) / wall;
    const double max_rate = 1e6 / line.transaction_us(8, 13, 1000.0);
    std::string split;
    for (const auto& [name, cpu] : threads1) {
        const auto before = threads0.find(name);
        const double d = 100.0 * (cpu - (before == threads0.end() ? 0.0 : before->second)) / wall;
        split += fmt::format("{}{} {:.2f}%", split.empty() ? "" : ", ", name == "drivebusd" ? "main" : name, d);
    }
    Row r{"7",
          fmt::format("drivebusd cost: 31 drives at 19200 8N1 as fast as allowed, {} subscribed clients", clients)};
    r.samples = static_cast<std::size_t>(r1 - r0);
    r.notes = fmt::format(
        "CPU **{:.2f}%** of one core over {:.0f} s (utime+stime; by thread: {}); peak RssAnon "
        "**{:.1f} MiB** (heap and stacks, sampled every 100 ms; VmHWM with shared memory: {:.1f} "
        "MiB); VmLck **{:.1f} MiB** (locked at the end, real-time defaults); {:.1f} transactions/s "
        "= {:.3f} of the maximum{}",
        share, wall, split, static_cast<double>(peak_anon) / 1024.0, static_cast<double>(s1.hwm_kb) / 1024.0,
        static_cast<double>(s1.locked_kb) / 1024.0, rate, rate / max_rate,
        clients > 0 ? fmt::format("; clients got {} snapshots", received) : "");
    if (clients > 0) {
        r.target = "CPU < 2%, heap RSS < 16 MiB";
        r.met = share < 2.0 && peak_anon < 16 * 1024;
    }
    rows.push_back(r);
}

void cost(const Options& o, std::vector<Row>& rows) {
    cost_run(o, rows, 16);
    cost_run(o, rows, 0);  // what the subscribers cost, by difference
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string key = argv[i];
        if (key == "--smoke") {
            o.smoke = true;
        } else if (key == "--only" && i + 1 < argc) {
            std::istringstream in(argv[++i]);
            std::string item;
            while (std::getline(in, item, ',')) {
                o.only.insert(std::atoi(item.c_str()));
            }
        } else if (key == "--samples" && i + 1 < argc) {
            o.sample_count = static_cast<std::size_t>(std::max(1, std::atoi(argv[++i])));
        } else if (key == "--markdown" && i + 1 < argc) {
            o.markdown = argv[++i];
        } else {
            std::fprintf(stderr, "usage: bench_suite [--smoke] [--samples N] [--only 1,2,...] [--markdown FILE]\n");
            return 2;
        }
    }
    ::signal(SIGPIPE, SIG_IGN);
    std::vector<Row> rows;
    const std::vector<std::pair<std::vector<int>, std::function<void(const Options&, std::vector<Row>&)>>> items{
        {{0}, floors}, {{1, 2, 3}, latency}, {{4}, efficiency}, {{5}, gap},
        {{6}, jitter}, {{7}, cost},          {{8}, wire_rules}};
    int failures = 0;
    for (const auto& [numbers_of, run] : items) {
        if (std::ranges::none_of(numbers_of, [&](int i) { return o.runs(i); })) {
            continue;
        }
        try {
            run(o, rows);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "bench: item %d failed: %s\n", numbers_of.front(), e.what());
            ++failures;
        }
    }
    std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.item < b.item; });
    const std::string text = table(rows);
    std::fputs(text.c_str(), stdout);
    if (!o.markdown.empty()) {
        std::ofstream(o.markdown) << text;
    }
    return failures == 0 ? 0 : 1;
}
