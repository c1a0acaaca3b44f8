// SPDX-License-Identifier: Apache-2.0
// drivebus-gateway end to end: drivebus-sim (an ATV21 "pump" at 1, an ATV58 "fan" at 2),
// drivebusd and the gateway as processes, and independent Modbus TCP clients through it:
// mbpoll, pymodbus's TCP client and libmodbus's. Values are compared with the simulator's.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <regex>
#include <tuple>

#include "stack.hpp"
#include "tcp_peer.hpp"

using namespace drivebus;
using namespace drivebus::test;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

// The gateway on a free loopback port, writes allowed from 127.0.0.1.
class Gateway {
public:
    Gateway(const Stack& stack, const std::string& extra = "write_from = [\"127.0.0.1/32\"]\n") {
        config_ = stack.dir() / ("gateway-" + std::to_string(++count_) + ".toml");
        std::ofstream(config_) << "[gateway]\nlisten = \"127.0.0.1:0\"\nmax_age = \"1s\"\n" << extra;
        child_ = std::make_unique<Child>(std::vector<std::string>{GATEWAY_PATH, "--config", config_.string()});
        const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
        std::smatch m;
        if (!wait_until(
                [&] {
                    const auto out = child_->output();
                    if (std::regex_search(out, m, listening)) {
                        port_ = std::stoi(m[1]);
                        return true;
                    }
                    return out.find("error:") != std::string::npos;  // it has given up
                },
                20s) ||
            port_ == 0) {
            throw std::runtime_error("drivebus-gateway did not come up: " + child_->output());
        }
    }
    [[nodiscard]] std::string port() const { return std::to_string(port_); }
    [[nodiscard]] std::uint16_t port_number() const { return static_cast<std::uint16_t>(port_); }
    [[nodiscard]] int pid() const { return child_->pid(); }
    [[nodiscard]] std::string output() const { return child_->output(); }
    // Its exit status once it has ended by itself (SIGTERM first if it has not): -1 for a signal.
    int stop() { return child_->stop(); }

private:
    static inline int count_ = 0;
    fs::path config_;
    std::unique_ptr<Child> child_;
    int port_ = 0;
};

// Values no default would give: a client reading zeros where the drive holds these is caught.
// Then waits until drivebusd has polled them (a polled value may be up to max_age old: a client
// reading before the next poll would rightly get the one before).
void poke_values(Stack& stack, const Gateway& gateway) {
    for (const auto& [address, reg, value] : {std::tuple{1, "FD06", "0x1234"}, std::tuple{2, "W450", "111"},
                                              std::tuple{2, "W451", "222"}, std::tuple{2, "W452", "333"}}) {
        const auto answer =
            stack.sim().command(std::string("set ") + std::to_string(address) + " " + reg + " " + value);
        if (answer != "ok") {
            throw std::runtime_error(std::string("sim set ") + reg + ": " + answer);
        }
    }
    if (stack.sim_register(1, "FD06") != 0x1234 || stack.sim_register(2, "W452") != 333) {
        throw std::runtime_error("the simulator did not keep the values set");
    }
    drivebus::gateway::test::Peer peer(gateway.port_number());
    const bool polled = wait_until(
        [&] {
            peer.request(1, 2, {0x03, 0x01, 0xC2, 0x00, 0x03});  // W450..W452
            const auto a = peer.answer();
            return a && a->second == drivebus::gateway::test::Bytes{0x03, 0x06, 0x00, 0x6F, 0x00, 0xDE, 0x01, 0x4D};
        },
        10s);
    if (!polled) {
        throw std::runtime_error("drivebusd never polled the fan's new W450..W452");
    }
}

StackOptions leased() {
    StackOptions o;
    o.drive_extra = "  lease = \"1s\"\n  fallback = \"stop\"\n";
    return o;
}

// mbpoll's one value: "[64768]: \t0x0BB8".
std::optional<unsigned> mbpoll_value(const std::string& out) {
    std::smatch m;
    if (std::regex_search(out, m, std::regex("\\]:\\s+0x([0-9A-Fa-f]+)"))) {
        return std::stoul(m[1], nullptr, 16);
    }
    return std::nullopt;
}

// mbpoll OPTIONS 127.0.0.1 [VALUES...]: values given are written.
std::pair<int, std::string> mbpoll(const Gateway& g, const std::vector<std::string>& options,
                                   const std::vector<std::string>& values = {}) {
    std::vector<std::string> argv{"/usr/bin/mbpoll", "-m", "tcp", "-p", g.port(), "-0", "-1", "-o", "5"};
    argv.insert(argv.end(), options.begin(), options.end());
    argv.emplace_back("127.0.0.1");
    argv.insert(argv.end(), values.begin(), values.end());
    return run_program(argv);
}

}  // namespace

TEST(GatewayPeers, MbpollReadsAndWritesThroughTheGateway) {
    Stack stack(leased());
    Gateway gateway(stack);
    poke_values(stack, gateway);
    // An unpolled register: from the drive, through drivebusd.
    auto [status, out] = mbpoll(gateway, {"-a", "1", "-r", "64774", "-t", "4:hex"});  // FD06
    ASSERT_EQ(status, 0) << out;
    EXPECT_EQ(mbpoll_value(out), stack.sim_register(1, "FD06")) << out;
    // FC04 reads the same register space.
    std::tie(status, out) = mbpoll(gateway, {"-a", "1", "-r", "64774", "-t", "3:hex"});
    ASSERT_EQ(status, 0) << out;
    EXPECT_EQ(mbpoll_value(out), stack.sim_register(1, "FD06")) << out;
    // A write reaches the drive; the polled register then reads back what was written.
    std::tie(status, out) = mbpoll(gateway, {"-a", "1", "-r", "64001"}, {"2345"});  // FA01
    ASSERT_EQ(status, 0) << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 2345);
    std::tie(status, out) = mbpoll(gateway, {"-a", "1", "-r", "64001", "-t", "4:hex"});
    ASSERT_EQ(status, 0) << out;
    EXPECT_EQ(mbpoll_value(out), 2345U) << out;
    // The fan's polled W450.
    std::tie(status, out) = mbpoll(gateway, {"-a", "2", "-r", "450", "-t", "4:hex"});
    ASSERT_EQ(status, 0) << out;
    EXPECT_EQ(mbpoll_value(out), stack.sim_register(2, "W450")) << out;
    // No drive at unit 99: the gateway's exception, in mbpoll's words.
    std::tie(status, out) = mbpoll(gateway, {"-a", "99", "-r", "64774"});
    EXPECT_NE(status, 0) << out;
    EXPECT_NE(out.find("Gateway path unavailable"), std::string::npos) << out;
}

TEST(GatewayPeers, PymodbusTcpClientReadsWritesIdentifiesAndGetsTypedExceptions) {
    Stack stack(leased());
    Gateway gateway(stack);
    poke_values(stack, gateway);
    const auto [status, out] = run_program({"/usr/bin/python3", PYMODBUS_TCP, gateway.port(), "check"});
    ASSERT_EQ(status, 0) << out;
    SCOPED_TRACE(out);
    const auto line = out.substr(out.find('{'));
    const auto r = nlohmann::json::parse(line.substr(0, line.find('\n')));
    EXPECT_EQ(r["fd06"], stack.sim_register(1, "FD06")) << out;
    EXPECT_EQ(r["fd06_input"], stack.sim_register(1, "FD06")) << out;
    EXPECT_EQ(r["w450"], (std::vector<unsigned>{stack.sim_register(2, "W450"), stack.sim_register(2, "W451"),
                                                stack.sim_register(2, "W452")}))
        << out;
    EXPECT_EQ(r["write_fa01"], "ok") << out;
    EXPECT_EQ(r["write_fa01_fc16"], "ok") << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 1600);
    ASSERT_TRUE(r["ident"].is_object()) << out;
    EXPECT_FALSE(r["ident"]["0"].get<std::string>().empty()) << out;
    const auto exception = [&](const char* key) { return r[key].is_object() ? r[key]["exception"] : r[key]; };
    EXPECT_EQ(exception("fan_ident"), 1);  // the ATV58 has no FC43
    EXPECT_EQ(r["echo"], nlohmann::json::array({0xA537}));
    EXPECT_EQ(exception("unit99"), 0x0A);
    EXPECT_EQ(exception("two_words"), 3);
    EXPECT_EQ(exception("write_fd06"), 2);
}

TEST(GatewayPeers, LibmodbusTcpClientReadsWhatTheSimulatorHolds) {
    Stack stack(leased());
    Gateway gateway(stack);
    poke_values(stack, gateway);
    const auto [status, out] = run_program({LIBMODBUS_TCP_CLIENT, gateway.port()});
    ASSERT_EQ(status, 0) << out;

    EXPECT_NE(out.find("fd06 " + std::to_string(stack.sim_register(1, "FD06")) + "\n"), std::string::npos) << out;
    EXPECT_NE(out.find("fa01 1700\n"), std::string::npos) << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), 1700);
    EXPECT_NE(out.find("w450 " + std::to_string(stack.sim_register(2, "W450")) + " " +
                       std::to_string(stack.sim_register(2, "W451")) + " " +
                       std::to_string(stack.sim_register(2, "W452")) + "\n"),
              std::string::npos)
        << out;
    EXPECT_NE(out.find("unit99 Gateway path unavailable"), std::string::npos) << out;
    EXPECT_NE(out.find("write_fd06 Illegal data address"), std::string::npos) << out;
}

TEST(GatewayPeers, WritesAreRefusedFromUnlistedSourcesAndLogged) {
    Stack stack(leased());
    Gateway gateway(stack, "write_from = [\"10.0.0.0/8\"]\n");
    const auto before = stack.sim_register(1, "FA01");
    const auto [status, out] =
        run_program({"/usr/bin/python3", PYMODBUS_TCP, gateway.port(), "write", "0xFA01", "999"});
    ASSERT_EQ(status, 0) << out;
    EXPECT_NE(out.find("exception 1"), std::string::npos) << out;
    EXPECT_EQ(stack.sim_register(1, "FA01"), before);
    EXPECT_TRUE(
        wait_until([&] { return gateway.output().find("write refused from 127.0.0.1:") != std::string::npos; }, 5s))
        << gateway.output();
}

// A TCP client commands the pump; another is refused while it holds; it disappears (SIGKILL):
// the lease runs out and drivebusd applies the fallback (stop).
TEST(GatewayPeers, AWriterThatDisappearsLetsTheDriveReachItsFallback) {
    Stack stack(leased());
    Gateway gateway(stack);
    Child holder({"/usr/bin/python3", PYMODBUS_TCP, gateway.port(), "hold", "3000"});
    ASSERT_TRUE(wait_until([&] { return holder.output().find("holding") != std::string::npos; }, 20s))
        << holder.output() << gateway.output();
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") == 3000; }, 20s))
        << "FD00 = " << stack.sim_register(1, "FD00");
    const auto [status, out] =
        run_program({"/usr/bin/python3", PYMODBUS_TCP, gateway.port(), "write", "0xFA01", "500"});
    ASSERT_EQ(status, 0) << out;
    EXPECT_NE(out.find("exception 6"), std::string::npos) << out;  // busy: the lease is held
    EXPECT_EQ(stack.sim_register(1, "FA01"), 3000);

    ASSERT_EQ(::kill(holder.pid(), SIGKILL), 0);
    // The ramp-stop command word is written once the 1 s lease has run out: the drive stops.
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") != 0xC400; }, 5s)) << stack.daemon_output();
    EXPECT_TRUE(wait_until([&] { return stack.sim_register(1, "FD00") == 0; }, 20s))
        << "FD00 = " << stack.sim_register(1, "FD00");
    EXPECT_NE(stack.daemon_output().find("ran out"), std::string::npos) << stack.daemon_output();
}

// SIGKILL of the gateway in the middle of traffic: drivebusd and its other clients go on, and
// the drive the gateway's client commanded reaches its fallback.
TEST(GatewayPeers, KillingTheGatewayMidTrafficLeavesDrivebusdAndItsClientsAlone) {
    Stack stack(leased());
    auto gateway = std::make_unique<Gateway>(stack);
    Child holder({"/usr/bin/python3", PYMODBUS_TCP, gateway->port(), "hold", "2000"});
    ASSERT_TRUE(wait_until([&] { return holder.output().find("holding") != std::string::npos; }, 20s))
        << holder.output();
    Child reader({TEST_CLIENT_PATH, stack.bus(), "flood", "FD06"});
    ASSERT_TRUE(wait_until([&] { return reader.output().find("ready") != std::string::npos; }, 20s)) << reader.output();
    Child tcp_flood({LIBMODBUS_TCP_CLIENT, gateway->port(), "flood"});
    ASSERT_TRUE(wait_until([&] { return tcp_flood.output().find("ready") != std::string::npos; }, 20s))
        << tcp_flood.output();

    ASSERT_EQ(::kill(gateway->pid(), SIGKILL), 0);
    ASSERT_TRUE(wait_until([&] { return stack.sim_register(1, "FA00") != 0xC400; }, 5s)) << stack.daemon_output();
    // drivebusd is alive and serves its other clients: the flood still runs, a new client reads.
    EXPECT_EQ(::kill(stack.daemon_pid(), 0), 0);
    const auto [status, out] = run_program({TEST_CLIENT_PATH, stack.bus(), "read", "FD06", "3"});
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("value " + std::to_string(stack.sim_register(1, "FD06"))), std::string::npos) << out;
    EXPECT_EQ(reader.output().find("error"), std::string::npos) << reader.output();
    EXPECT_EQ(::waitpid(reader.pid(), nullptr, WNOHANG), 0) << reader.output();
    // A new gateway serves at once.
    Gateway again(stack);
    const auto [s2, o2] = run_program({"/usr/bin/python3", PYMODBUS_TCP, again.port(), "write", "0xFA01", "1234"});
    EXPECT_EQ(s2, 0) << o2;
    EXPECT_NE(o2.find("ok"), std::string::npos) << o2;
}

// drivebusd goes away: the gateway cannot reach a new RouDi from the same process (iceoryx), so
// it ends, 69, for systemd to start it again (or iceoryx aborts it first: a signal).
TEST(GatewayPeers, DrivebusdGoneEndsTheGatewayForSystemdToStartItAgain) {
    Stack stack(leased());
    Gateway gateway(stack);
    EXPECT_EQ(stack.stop_daemon(), 0) << stack.daemon_output();
    const bool ended = wait_until(
        [&] {
            const auto out = gateway.output();
            siginfo_t info{};
            const bool exited =
                ::waitid(P_PID, static_cast<id_t>(gateway.pid()), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
                info.si_pid == gateway.pid();
            return exited || out.find("drivebusd has gone silent") != std::string::npos;
        },
        30s);
    EXPECT_TRUE(ended) << gateway.output();
    const int status = gateway.stop();
    EXPECT_TRUE(status == 69 || status == -1) << "exit status " << status << "\n" << gateway.output();
}
