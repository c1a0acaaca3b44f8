// SPDX-License-Identifier: Apache-2.0
// drivebusctl as a process against the whole stack (drivebus-sim with an ATV21 "pump" at 1 and
// an ATV58 "fan" at 2, drivebusd with its embedded RouDi): what it prints, its exit status, and
// what reached the simulated drives. Every test holds the ctest RESOURCE_LOCK "iceoryx".
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "cannot_run.hpp"
#include "read_json.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

struct Run {
    int status = -1;
    std::string out;  // stdout
    std::string err;  // stderr
};

// Runs drivebusctl with `args`; its stdout and stderr apart.
Run ctl(const std::vector<std::string>& args) {
    static int n = 0;
    const auto err_file = fs::temp_directory_path() /
                          ("drivebusctl-test-" + std::to_string(::getpid()) + "-" + std::to_string(n++) + ".err");
    std::vector<std::string> argv = {
        "/bin/sh", "-c", "f=$1; shift; exec \"$@\" 2>\"$f\"", "sh", err_file.string(), DRIVEBUSCTL_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    auto [status, out] = run_program(argv);
    std::stringstream err;
    err << std::ifstream(err_file).rdbuf();
    std::error_code ec;
    fs::remove(err_file, ec);
    return {status, out, err.str()};
}

std::vector<std::string> with_bus(const Stack& stack, std::vector<std::string> args) {
    args.insert(args.begin(), {"--bus", stack.bus()});
    return args;
}

std::string describe(const Run& r) {
    return "exit " + std::to_string(r.status) + (r.status == -1 ? " (killed: still running after 10 s)" : "") +
           "\nstdout:\n" + r.out + "stderr:\n" + r.err;
}

// One line on stderr, "drivebusctl: ..." that contains `text`.
void expect_one_line_error(const Run& r, const std::string& text) {
    EXPECT_EQ(r.err.rfind("drivebusctl: ", 0), 0U) << describe(r);
    EXPECT_EQ(std::ranges::count(r.err, '\n'), 1) << describe(r);
    EXPECT_NE(r.err.find(text), std::string::npos) << "wanted '" << text << "'\n" << describe(r);
}

void sim_set(Stack& stack, int address, const std::string& reg, int value) {
    const auto reply = stack.sim().command("set " + std::to_string(address) + " " + reg + " " + std::to_string(value));
    ASSERT_EQ(reply.rfind("ok", 0), 0U) << reply;
}

StackOptions unpaced() {
    StackOptions o;
    o.paced = false;  // replies written at once: no pacing stalls on a loaded machine
    return o;
}

// No polls: nothing but drivebusctl's own requests reaches the simulator, so its request
// counter shows whether a command went on the wire.
StackOptions quiet() {
    auto o = unpaced();
    o.polls = false;
    return o;
}

// Waits until `drivebusctl --json list` shows both drives online.
bool both_online(const Stack& stack) {
    return wait_until(
        [&] {
            const auto r = ctl(with_bus(stack, {"--json", "list"}));
            if (r.status != 0) {
                return false;
            }
            const auto doc = json::parse(r.out);
            const auto& drives = doc["buses"][0]["drives"];
            return drives.find("name", "pump")["health"].str() == "online" &&
                   drives.find("name", "fan")["health"].str() == "online";
        },
        20s);
}

// ---- reads ----

TEST(CtlStack, ReadByNameShowsAddressRawEngineeringValueAndTitle) {
    Stack stack(unpaced());
    sim_set(stack, 1, "FA01", 1234);
    const auto r = ctl(with_bus(stack, {"read", "pump", "FA01"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    EXPECT_EQ(r.out, "FA01  0xFA01  1234  12.34 Hz  Frequency reference\n") << describe(r);
    EXPECT_EQ(r.err, "");

    const auto fd00 = ctl(with_bus(stack, {"read", "pump", "FD00"}));
    ASSERT_EQ(fd00.status, 0) << describe(fd00);
    EXPECT_TRUE(std::regex_match(fd00.out, std::regex("FD00  0xFD00  \\d+  \\d+\\.\\d\\d Hz  Output frequency\n")))
        << describe(fd00);
}

TEST(CtlStack, ReadByAddressAndNumberShowsTheBitsSet) {
    Stack stack(unpaced());
    const auto r = ctl(with_bus(stack, {"read", "1", "0xFD01"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    const auto raw = stack.sim_register(1, "FD01");
    EXPECT_EQ(r.out.rfind("FD01  0xFD01  " + std::to_string(raw), 0), 0U) << describe(r);
    EXPECT_NE(r.out.find("Status word"), std::string::npos) << describe(r);
    if ((raw & 0x4000) != 0) {
        EXPECT_NE(r.out.find("\n    bit 14 Ready\n"), std::string::npos) << describe(r);
    }
}

TEST(CtlStack, ReadSeveralRegistersOfTheFan) {
    Stack stack(unpaced());
    sim_set(stack, 2, "W450", 11);
    sim_set(stack, 2, "W451", 22);
    sim_set(stack, 2, "W452", 0x1234);
    const auto r = ctl(with_bus(stack, {"read", "fan", "W450", "3"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    EXPECT_EQ(r.out,
              "W450  0x01C2  11    Supervision word 450\n"
              "W451  0x01C3  22    Supervision word 451\n"
              "W452  0x01C4  4660  Supervision word 452\n")
        << describe(r);

    const auto j = ctl(with_bus(stack, {"--json", "read", "fan", "W450", "3"}));
    ASSERT_EQ(j.status, 0) << describe(j);
    const auto doc = json::parse(j.out);
    EXPECT_EQ(doc["drive"].str(), "fan");
    EXPECT_EQ(doc["source"].str(), "bus");
    ASSERT_EQ(doc["registers"].items.size(), 3U);
    EXPECT_EQ(doc["registers"][0]["name"].str(), "W450");
    EXPECT_DOUBLE_EQ(doc["registers"][0]["address"].num(), 450);
    EXPECT_DOUBLE_EQ(doc["registers"][2]["raw"].num(), 0x1234);
}

// ---- writes ----

TEST(CtlStack, WriteARawValue) {
    Stack stack(unpaced());
    const auto r = ctl(with_bus(stack, {"write", "pump", "FA51", "300"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    EXPECT_EQ(stack.sim_register(1, "FA51"), 300);
    EXPECT_NE(r.out.find("FA51  0xFA51  300"), std::string::npos) << describe(r);
    EXPECT_EQ(r.err, "") << "FA51 takes no lease: nothing to release";

    const auto hex = ctl(with_bus(stack, {"write", "pump", "0xFA51", "0x1F4"}));
    ASSERT_EQ(hex.status, 0) << describe(hex);
    EXPECT_EQ(stack.sim_register(1, "FA51"), 500);
}

TEST(CtlStack, WriteWithTheUnitGoesThroughTheScaleAndGivesTheLeaseBack) {
    Stack stack(unpaced());
    const auto r = ctl(with_bus(stack, {"write", "pump", "FA01", "30Hz"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000);
    EXPECT_NE(r.out.find("FA01  0xFA01  3000  30.00 Hz  Frequency reference"), std::string::npos) << describe(r);
    expect_one_line_error(r, "released the control lease of drive 'pump'");
    EXPECT_TRUE(wait_until(
        [&] {
            return stack.daemon_output().find("drivebusctl[") != std::string::npos &&
                   stack.daemon_output().find("released the control lease") != std::string::npos;
        },
        5s))
        << stack.daemon_output();
    // The lease is free again (drivebusd republishes the snapshot's lease state).
    EXPECT_TRUE(wait_until(
        [&] {
            const auto s = ctl(with_bus(stack, {"--json", "status", "pump"}));
            return s.status == 0 && json::parse(s.out)["lease"]["state"].str() == "free";
        },
        10s));

    // The unit as an argument of its own, and --json.
    const auto j = ctl(with_bus(stack, {"--json", "write", "pump", "FA01", "30.5", "Hz"}));
    ASSERT_EQ(j.status, 0) << describe(j);
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3050);
    const auto doc = json::parse(j.out);
    EXPECT_DOUBLE_EQ(doc["written"][0]["raw"].num(), 3050);
    EXPECT_DOUBLE_EQ(doc["written"][0]["value"].num(), 30.5);
    EXPECT_EQ(doc["lease_released"].boolean, true);
    EXPECT_DOUBLE_EQ(doc["function"].num(), 6);
}

TEST(CtlStack, BadValueSyntaxIsAUsageErrorAndNeverReachesTheBus) {
    Stack stack(quiet());
    const auto before = stack.sim_requests();
    for (const auto& [value, message] :
         std::vector<std::pair<std::string, std::string>>{{"30s", "FA01 is in Hz, not s"},
                                                          {"30.5", "give it with its unit (30.5 Hz)"},
                                                          {"fast", "is not a value"},
                                                          {"70000", "does not fit in a 16-bit register"}}) {
        const auto r = ctl(with_bus(stack, {"write", "pump", "FA01", value}));
        EXPECT_EQ(r.status, 2) << describe(r);
        expect_one_line_error(r, message);
    }
    EXPECT_EQ(stack.sim_requests(), before);
}

TEST(CtlStack, AnExceptionFromTheDriveExitsOne) {
    Stack stack(unpaced());
    // FA01's profile gives no maximum (it is FH, a setting); the drive refuses above 80 Hz.
    const auto r = ctl(with_bus(stack, {"write", "pump", "FA01", "90Hz"}));
    EXPECT_EQ(r.status, 1) << describe(r);
    EXPECT_NE(r.err.find("drivebusctl: write pump FA01: drive 'pump' answered exception 3 (illegal data value)\n"),
              std::string::npos)
        << describe(r);
    // drivebusd gave it the lease before the bus said no: drivebusctl gives it back all the same.
    EXPECT_NE(r.err.find("drivebusctl: released the control lease of drive 'pump'"), std::string::npos) << describe(r);
    EXPECT_EQ(stack.sim_register(1, "FA01"), 0);
}

// ---- a request given up ----

// `--timeout` shorter than the drive takes: drivebusctl withdraws the request and says which
// happened. On the wire already, its outcome is unknown (exit 8, and the drive did get it);
// queued behind another write, it was never sent (exit 7, and the drive never got it).
TEST(CtlStack, ARequestGivenUpIsWithdrawnOrSaidToBeSentAndTheDriveAgrees) {
    Stack stack(quiet());
    // The drive answers 60 ms late, within the bus's 100 ms response time-out: a write is on
    // the wire at once and its reply comes after drivebusctl's 20 ms.
    // (On a loaded machine the withdrawal may reach drivebusd only once the write has finished:
    // then drivebusctl is told its result, exit 0. Tried until exit 8 is seen, five times at most.)
    ASSERT_EQ(stack.sim().command("fault 1 late=60ms").rfind("ok", 0), 0U);
    bool unknown_seen = false;
    for (int value = 551; value <= 555 && !unknown_seen; ++value) {
        const auto sent = ctl(with_bus(stack, {"--timeout", "10ms", "write", "pump", "FA51", std::to_string(value)}));
        ASSERT_TRUE(sent.status == 8 || sent.status == 0) << describe(sent);
        if (sent.status == 8) {
            unknown_seen = true;
            expect_one_line_error(sent, "had already been sent: its outcome is unknown");
        }
        EXPECT_TRUE(wait_until([&] { return stack.sim_register(1, "FA51") == value; }, 10s))
            << "it was sent, and applied";
    }
    EXPECT_TRUE(unknown_seen) << "five writes 60 ms long all finished within drivebusctl's 10 ms";

    // The drive answers 900 ms late, past every attempt's time-out and guard: a write keeps the
    // line for its four attempts and more, and one behind it waits.
    ASSERT_EQ(stack.sim().command("fault 1 late=900ms").rfind("ok", 0), 0U);
    const auto before = stack.sim_requests();
    test::Run first;
    {
        std::jthread busy([&] { first = ctl(with_bus(stack, {"--timeout", "10s", "write", "pump", "FA51", "111"})); });
        ASSERT_TRUE(wait_until([&] { return stack.sim_requests() > before; }, 10s)) << "the first write went out";
        const auto queued = ctl(with_bus(stack, {"--timeout", "50ms", "write", "pump", "FA51", "777"}));
        EXPECT_EQ(queued.status, 7) << describe(queued);
        expect_one_line_error(queued, "was withdrawn before it reached the drive: nothing was sent");
    }
    EXPECT_NE(first.status, 7) << describe(first);
    EXPECT_EQ(stack.sim_register(1, "FA51"), 111) << "the withdrawn 777 never reached the drive";
}

// ---- identify, scan ----

TEST(CtlStack, IdentifyShowsVendorProductCodeAndRevision) {
    Stack stack(unpaced());
    const auto r = ctl(with_bus(stack, {"identify", "pump"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    EXPECT_NE(r.out.find("vendor        Schneider Electric\n"), std::string::npos) << describe(r);
    EXPECT_NE(r.out.find("product code  ATV21H075M3X\n"), std::string::npos) << describe(r);
    EXPECT_NE(r.out.find("revision      0201\n"), std::string::npos) << describe(r);

    const auto j = ctl(with_bus(stack, {"--json", "identify", "pump"}));
    ASSERT_EQ(j.status, 0) << describe(j);
    const auto doc = json::parse(j.out);
    EXPECT_EQ(doc["vendor"].str(), "Schneider Electric");
    EXPECT_EQ(doc["product_code"].str(), "ATV21H075M3X");
    EXPECT_EQ(doc["revision"].str(), "0201");
}

TEST(CtlStack, ScanFindsExactlyTheTwoDrives) {
    Stack stack(unpaced());
    const auto r = ctl(with_bus(stack, {"--json", "scan", "--from", "1", "--to", "4"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    const auto doc = json::parse(r.out);
    std::set<int> found;
    for (const auto& item : doc["found"].items) {
        found.insert(static_cast<int>(item["address"].num()));
    }
    EXPECT_EQ(found, (std::set<int>{1, 2})) << r.out;
    EXPECT_EQ(doc["found"].find("drive", "pump")["address"].num(), 1);
    EXPECT_EQ(doc["found"].find("drive", "fan")["address"].num(), 2);

    const auto text = ctl(with_bus(stack, {"scan", "--from", "1", "--to", "4"}));
    ASSERT_EQ(text.status, 0) << describe(text);
    EXPECT_TRUE(std::regex_search(text.out, std::regex("\n1 +pump +")) &&
                std::regex_search(text.out, std::regex("\n2 +fan +")))
        << describe(text);
    EXPECT_EQ(text.out.find("\n3 "), std::string::npos) << describe(text);
    EXPECT_NE(text.out.find("2 of 4 addresses answered"), std::string::npos) << describe(text);
}

// ---- list, status ----

TEST(CtlStack, ListAndStatus) {
    Stack stack(unpaced());
    ASSERT_TRUE(both_online(stack)) << ctl({"list"}).out;

    const auto list = ctl({"list"});  // the only bus: no --bus needed
    ASSERT_EQ(list.status, 0) << describe(list);
    EXPECT_NE(list.out.find("bus " + stack.bus() + ": up, "), std::string::npos) << describe(list);
    // TIME-OUT: the pump's F803 once its check is in a bus status (once a second); the fan's
    // profile names none.
    EXPECT_NE(list.out.find("  pump  1        atv21    online  "), std::string::npos) << describe(list);
    EXPECT_NE(list.out.find("  fan   2        atv58    online  -\n"), std::string::npos) << describe(list);

    const auto bus = ctl({"status"});
    ASSERT_EQ(bus.status, 0) << describe(bus);
    EXPECT_NE(bus.out.find("state          up\n"), std::string::npos) << describe(bus);
    EXPECT_NE(bus.out.find("drives         2 of 2 online\n"), std::string::npos) << describe(bus);
    EXPECT_NE(bus.out.find("reply latency  mean "), std::string::npos) << describe(bus);

    const auto bus_json = json::parse(ctl({"--json", "status"}).out);
    EXPECT_EQ(bus_json["bus"].str(), stack.bus());
    EXPECT_EQ(bus_json["up"].boolean, true);
    EXPECT_DOUBLE_EQ(bus_json["drives_online"].num(), 2);
    EXPECT_GT(bus_json["counters"]["replies"].num(), 0);
    EXPECT_EQ(bus_json["drives"].find("name", "fan")["profile"].str(), "atv58");

    const auto pump = ctl(with_bus(stack, {"status", "pump"}));
    ASSERT_EQ(pump.status, 0) << describe(pump);
    EXPECT_NE(pump.out.find("drive     pump (address 1, profile atv21, bus " + stack.bus() + ")"), std::string::npos)
        << describe(pump);
    EXPECT_NE(pump.out.find("health    online\n"), std::string::npos) << describe(pump);
    EXPECT_NE(pump.out.find("state     stopped, 0.00 Hz, no fault"), std::string::npos) << describe(pump);
    EXPECT_NE(pump.out.find("lease     free"), std::string::npos) << describe(pump);
    EXPECT_TRUE(
        std::regex_search(pump.out, std::regex("\nFD00 +0xFD00 +0 +0\\.00 Hz +yes +\\d+ ms +Output frequency\n")))
        << describe(pump);

    const auto pump_json = json::parse(ctl(with_bus(stack, {"--json", "status", "pump"})).out);
    EXPECT_EQ(pump_json["drive"].str(), "pump");
    EXPECT_EQ(pump_json["health"].str(), "online");
    EXPECT_EQ(pump_json["state"]["running"].boolean, false);
    EXPECT_EQ(pump_json["lease"]["state"].str(), "free");
    EXPECT_EQ(pump_json["registers"].find("name", "FD01")["valid"].boolean, true);
    EXPECT_EQ(pump_json["registers"].find("name", "FD00")["unit"].str(), "Hz");

    const auto fan = ctl(with_bus(stack, {"status", "fan"}));
    ASSERT_EQ(fan.status, 0) << describe(fan);
    EXPECT_EQ(fan.out.find("\nstate "), std::string::npos) << "the atv58 profile says nothing of its state";
    EXPECT_NE(fan.out.find("\nW450  0x01C2"), std::string::npos) << describe(fan);
}

// ---- watch ----

class TmuxSession {
public:
    explicit TmuxSession(const std::string& command)
        : socket_("drivebusctl-test-" + std::to_string(::getpid())), name_("watch" + std::to_string(::getpid())) {
        started_ = tmux({"new-session", "-d", "-s", name_, "-x", "120", "-y", "30", command}).first == 0;
    }
    ~TmuxSession() { (void)tmux({"kill-server"}); }
    TmuxSession(const TmuxSession&) = delete;
    TmuxSession& operator=(const TmuxSession&) = delete;
    TmuxSession(TmuxSession&&) = delete;
    TmuxSession& operator=(TmuxSession&&) = delete;

    [[nodiscard]] bool started() const { return started_; }
    [[nodiscard]] std::string screen() const { return tmux({"capture-pane", "-p", "-t", name_}).second; }
    void keys(const std::string& keys) const { (void)tmux({"send-keys", "-t", name_, keys}); }
    [[nodiscard]] bool running() const { return tmux({"has-session", "-t", name_}).first == 0; }

private:
    // On a server of its own (-L), apart from anyone else's tmux.
    [[nodiscard]] std::pair<int, std::string> tmux(std::vector<std::string> args) const {
        args.insert(args.begin(), {"/usr/bin/tmux", "-L", socket_});
        return run_program(args);
    }
    std::string socket_;
    std::string name_;
    bool started_ = false;
};

bool row_online(const std::string& screen, const std::string& drive) {
    return std::regex_search(screen, std::regex("\n" + drive + " +\\d+ +atv\\d+ +online +\\d"));
}

TEST(CtlStack, WatchRefreshesInPlaceInATerminalAndQuitsOnQ) {
    if (!fs::exists("/usr/bin/tmux")) {
        CANNOT_RUN() << "tmux is not installed (scripts/setup installs it)";
    }
    Stack stack(unpaced());
    TmuxSession tmux(std::string(DRIVEBUSCTL_PATH) + " --bus " + stack.bus() + " watch");
    ASSERT_TRUE(tmux.started());
    std::string screen;
    ASSERT_TRUE(wait_until(
        [&] {
            screen = tmux.screen();
            // The bus status comes once a second, the snapshots more often.
            return row_online(screen, "pump") && row_online(screen, "fan") &&
                   screen.find("bus " + stack.bus() + ": up, 2 of 2 drives online") != std::string::npos;
        },
        20s))
        << screen;
    EXPECT_TRUE(
        std::regex_search(screen, std::regex("\npump .* online .* (stopped|running forward), \\d+\\.\\d\\d Hz")))
        << screen;
    EXPECT_NE(screen.find("W450="), std::string::npos) << screen;
    // Live: the screen changes (ages, counters) and is redrawn in place, not scrolled.
    const auto first = screen;
    ASSERT_TRUE(wait_until(
        [&] {
            screen = tmux.screen();
            return screen != first && row_online(screen, "pump");
        },
        10s))
        << screen;
    std::size_t headers = 0;
    for (auto at = screen.find("DRIVE  ADDRESS"); at != std::string::npos; at = screen.find("DRIVE  ADDRESS", at + 1)) {
        ++headers;
    }
    EXPECT_EQ(headers, 1U) << screen;

    tmux.keys("q");
    EXPECT_TRUE(wait_until([&] { return !tmux.running(); }, 10s)) << tmux.screen();
}

TEST(CtlStack, WatchWithoutATerminalPrintsPlainTablesUntilSigterm) {
    Stack stack(unpaced());
    Child watch({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "watch", "--interval", "100ms"});
    ASSERT_TRUE(wait_until(
        [&] {
            const auto out = watch.output();
            std::size_t tables = 0;
            for (auto at = out.find("DRIVE  ADDRESS"); at != std::string::npos;
                 at = out.find("DRIVE  ADDRESS", at + 1)) {
                ++tables;
            }
            return tables >= 3 && row_online(out, "fan");
        },
        20s))
        << watch.output();
    EXPECT_EQ(watch.stop(), 0) << watch.output();
    EXPECT_EQ(watch.output().find('\x1b'), std::string::npos) << "no escape codes without a terminal";
}

TEST(CtlStack, WatchJsonIsOneObjectPerLine) {
    Stack stack(unpaced());
    Child watch({DRIVEBUSCTL_PATH, "--bus", stack.bus(), "--json", "watch", "--interval", "50ms"});
    ASSERT_TRUE(wait_until([&] { return std::ranges::count(watch.output(), '\n') >= 3; }, 20s)) << watch.output();
    EXPECT_EQ(watch.stop(), 0);
    std::istringstream lines(watch.output());
    int parsed = 0;
    for (std::string line; std::getline(lines, line);) {
        const auto doc = json::parse(line);
        EXPECT_EQ(doc["bus"]["name"].str(), stack.bus());
        EXPECT_EQ(doc["drives"][0]["name"].str(), "pump");
        EXPECT_EQ(doc["drives"][1]["name"].str(), "fan");
        ++parsed;
    }
    EXPECT_GE(parsed, 3);
}

// ---- rejections: drivebusd refuses before the bus ----

// The command exits with `status`, one line says why, and the simulator saw no request.
void expect_refused(Stack& stack, const std::vector<std::string>& args, int status, const std::string& message) {
    const auto before = stack.sim_requests();
    const auto r = ctl(with_bus(stack, args));
    EXPECT_EQ(r.status, status) << describe(r);
    expect_one_line_error(r, message);
    EXPECT_EQ(r.out, "") << describe(r);
    EXPECT_EQ(stack.sim_requests(), before) << "the refused request reached the drive";
}

TEST(CtlRejected, UnknownDriveIsAUsageError) {
    Stack stack(quiet());
    expect_refused(stack, {"read", "boiler", "FD00"}, 2, "has no drive 'boiler'; it has pump (1), fan (2)");
    expect_refused(stack, {"read", "9", "FD00"}, 2, "has no drive '9'");
    expect_refused(stack, {"read", "pump", "XYZ"}, 2, "'XYZ' is neither a register of profile atv21 nor a number");
}

TEST(CtlRejected, UnknownRegister) {
    Stack stack(quiet());
    expect_refused(stack, {"read", "pump", "0x1234"}, 3, "unknown register (register 0x1234)");
}

TEST(CtlRejected, ReadOnlyRegister) {
    Stack stack(quiet());
    expect_refused(stack, {"write", "pump", "FD00", "1"}, 3,
                   "read-only register (register 0xFD00); FD00 can only be read");
}

// No register of atv21.toml or atv58.toml is write-only: that rejection cannot be reached
// through these profiles.

TEST(CtlRejected, Quantity) {
    Stack stack(quiet());
    expect_refused(stack, {"read", "pump", "FD00", "2"}, 3,
                   "quantity out of range; profile atv21 reads at most 1 register per request");
    expect_refused(stack, {"read", "fan", "W450", "126"}, 3, "quantity out of range");
    expect_refused(stack, {"read", "fan", "W450", "0"}, 3, "quantity out of range");
}

TEST(CtlRejected, ValueOutOfRange) {
    Stack stack(quiet());
    expect_refused(stack, {"write", "pump", "F803", "101"}, 3,
                   "value out of range (register 0x0803); F803 takes 0..100");
    expect_refused(stack, {"write", "pump", "FA51", "1024"}, 3,
                   "value out of range (register 0xFA51); FA51 takes 0..1023");
}

TEST(CtlRejected, FunctionNotSupported) {
    Stack stack(quiet());
    expect_refused(stack, {"identify", "fan"}, 3,
                   "function not supported by the drive; profile atv58 has no device identification");
}

TEST(CtlRejected, JsonModeAddsAnErrorDocument) {
    Stack stack(quiet());
    const auto before = stack.sim_requests();
    const auto r = ctl(with_bus(stack, {"--json", "write", "pump", "F803", "101"}));
    EXPECT_EQ(r.status, 3) << describe(r);
    expect_one_line_error(r, "value out of range");
    const auto doc = json::parse(r.out);
    EXPECT_EQ(doc["error"]["kind"].str(), "rejected");
    EXPECT_NE(doc["error"]["message"].str().find("value out of range"), std::string::npos);
    EXPECT_EQ(stack.sim_requests(), before);
}

TEST(CtlRejected, AnotherClientsLeaseRefusesTheWriteUnlessTakenOver) {
    Stack stack(quiet());
    sim_set(stack, 1, "F803", 0);  // no Modbus time-out trip while nothing polls the drive
    Child holder({TEST_CLIENT_PATH, stack.bus(), "command", "30"});
    ASSERT_TRUE(wait_until([&] { return holder.output().find("holding") != std::string::npos; }, 10s))
        << holder.output();
    ASSERT_EQ(stack.sim_register(1, "FA01"), 3000);

    expect_refused(stack, {"write", "pump", "FA01", "1000"}, 4, "holds the control lease of drive 'pump'");
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000);
    const auto j = ctl(with_bus(stack, {"--json", "write", "pump", "FA01", "1000"}));
    EXPECT_EQ(j.status, 4) << describe(j);
    EXPECT_EQ(json::parse(j.out)["error"]["kind"].str(), "not_permitted");

    const auto r = ctl(with_bus(stack, {"write", "pump", "FA01", "1000", "--take-over"}));
    ASSERT_EQ(r.status, 0) << describe(r);
    EXPECT_EQ(stack.sim_register(1, "FA01"), 1000);
    expect_one_line_error(r, "released the control lease of drive 'pump'");
    EXPECT_NE(stack.daemon_output().find("took the control lease over"), std::string::npos) << stack.daemon_output();
}

// ---- no drivebusd, usage ----

TEST(CtlNoDaemon, ListSaysDrivebusdIsNotRunning) {
    ASSERT_TRUE(wait_until([] { return roudi_gone(); }, 60s)) << "a RouDi runs (/tmp/roudi): stop it first";
    const auto r = ctl({"list"});
    EXPECT_EQ(r.status, 5) << describe(r);
    expect_one_line_error(r, "drivebusd is not running");
    EXPECT_EQ(r.out, "");

    const auto j = ctl({"--json", "status", "pump"});
    EXPECT_EQ(j.status, 5) << describe(j);
    EXPECT_EQ(json::parse(j.out)["error"]["kind"].str(), "not_running");
}

TEST(CtlNoDaemon, UsageErrorsExitTwo) {
    for (const auto& args : std::vector<std::vector<std::string>>{{},
                                                                  {"frobnicate"},
                                                                  {"read", "pump"},
                                                                  {"write", "pump", "FA01"},
                                                                  {"--timeout", "5x", "list"},
                                                                  {"watch", "--interval", "0"},
                                                                  {"scan", "--from", "0"},
                                                                  {"scan", "--from", "5", "--to", "4"},
                                                                  {"read", "pump", "FD00", "70000"}}) {
        const auto r = ctl(args);
        std::string joined;
        for (const auto& a : args) {
            joined += a + " ";
        }
        EXPECT_EQ(r.status, 2) << joined << describe(r);
        EXPECT_EQ(r.err.rfind("drivebusctl: ", 0), 0U) << joined << describe(r);
        EXPECT_EQ(std::ranges::count(r.err, '\n'), 1) << joined << describe(r);
    }
    const auto help = ctl({"--help"});
    EXPECT_EQ(help.status, 0);
    EXPECT_NE(help.out.find("watch"), std::string::npos) << help.out;
}

}  // namespace
}  // namespace drivebus::test
