// SPDX-License-Identifier: Apache-2.0
// drivebus-sim on a pty, seen from the master's side: replies, pacing, every fault injection,
// the control socket and the command line.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "hex.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

const rtu::LineFormat k19200{19200, 8, rtu::Parity::None, 1};
const rtu::RequestAdu kReadFD00{1, rtu::ReadHoldingRegisters{0xFD00, 1}};
const rtu::RequestAdu kReadW450{2, rtu::ReadHoldingRegisters{450, 10}};
constexpr auto kTurnaround = 1ms;

std::vector<std::uint8_t> encoded(const rtu::RequestAdu& request) {
    const auto adu = rtu::encode_request(request).value();
    return {adu.bytes().begin(), adu.bytes().end()};
}

class SimLine : public ::testing::Test {
protected:
    SimProcess sim{{"--drive", "1:atv21", "--drive", "2:atv58", "--turnaround", "1ms"}};
    TestMaster master{sim.link(), k19200};

    // The earliest a paced reply of `reply_bytes` can have fully arrived after the write of a
    // `request_bytes` request returned: the request at wire speed, t3.5 for the drive to see
    // its end, the turnaround, the reply at wire speed.
    [[nodiscard]] rtu::Duration minimum_exchange(std::size_t request_bytes, std::size_t reply_bytes,
                                                 rtu::Duration extra = {}) const {
        const auto& t = master.timing();
        return t.character * static_cast<std::int64_t>(request_bytes - 1) + t.t3_5 + kTurnaround + extra +
               t.character * static_cast<std::int64_t>(reply_bytes);
    }
};

TEST_F(SimLine, AnswersBothDrives) {
    const auto r1 = master.transact(kReadFD00);
    ASSERT_TRUE(r1.decoded) << "no reply; read " << to_hex(r1.bytes);
    EXPECT_EQ(r1.bytes.size(), 7U);
    const auto r2 = master.transact(kReadW450);
    ASSERT_TRUE(r2.decoded);
    EXPECT_EQ(std::get<rtu::ReadHoldingRegistersResponse>(r2.decoded->pdu).values.size(), 10U);
    EXPECT_NE(sim.command("stats").find("requests=2 "), std::string::npos);
}

TEST_F(SimLine, PacedRepliesNeverArriveFasterThanTheWire) {
    for (int i = 0; i < 20; ++i) {
        const auto r = master.transact(kReadW450);
        ASSERT_TRUE(r.decoded) << "transaction " << i << ": read [" << to_hex(r.bytes) << "] " << r.discarded.size()
                               << " discarded; simulator " << sim.command("stats");
        // Every byte of the reply arrives no earlier than the wire allows.
        for (std::size_t k = 0; k < 25; ++k) {
            EXPECT_GE(r.byte_times[k] - r.written, minimum_exchange(8, k + 1)) << "transaction " << i << " byte " << k;
        }
    }
}

TEST_F(SimLine, IgnoresOtherAddressesAndBrokenFrames) {
    // A request for address 9 and a broken frame get nothing; the next request is answered.
    const auto other =
        master.transact(encoded({9, rtu::ReadHoldingRegisters{0, 1}}), {9, rtu::ReadHoldingRegisters{0, 1}}, 100ms);
    EXPECT_TRUE(other.bytes.empty());
    auto broken = encoded(kReadFD00);
    broken.back() ^= 0x55;
    const auto bad = master.transact(broken, kReadFD00, 100ms);
    EXPECT_TRUE(bad.bytes.empty());
    EXPECT_TRUE(master.transact(kReadFD00).decoded.has_value());
    const std::string stats = sim.command("stats");
    EXPECT_NE(stats.find("foreign=1 "), std::string::npos) << stats;
    EXPECT_NE(stats.find("broken=1 "), std::string::npos) << stats;
}

TEST_F(SimLine, CrcFault) {
    ASSERT_EQ(sim.command("fault 1 crc=1").rfind("ok", 0), 0U);
    // A loaded machine's pty can hold part of the reply back past t3.5, splitting it into two
    // frames (one of them too short): that is the pty, not the fault under test, so try again.
    auto r = master.transact(kReadFD00, 200ms);
    for (int attempt = 1; attempt < 5 && r.discarded.size() > 1; ++attempt) {
        r = master.transact(kReadFD00, 200ms);
    }
    EXPECT_FALSE(r.decoded);
    EXPECT_FALSE(r.reply);
    ASSERT_EQ(r.bytes.size(), 7U);
    EXPECT_FALSE(rtu::crc_ok(r.bytes));
    ASSERT_FALSE(r.discarded.empty());
    EXPECT_EQ(r.discarded.back().fault, rtu::FrameFault::CrcMismatch);
    ASSERT_EQ(sim.command("clear").rfind("ok", 0), 0U);
    EXPECT_TRUE(master.transact(kReadFD00).decoded.has_value());
}

TEST_F(SimLine, DropFault) {
    ASSERT_EQ(sim.command("fault 1 drop=1").rfind("ok", 0), 0U);
    // Drive 1 is silent: nothing arrives before drive 2's reply to the next request.
    const auto silent = master.transact(kReadFD00, 50ms);
    const auto answered = master.transact(kReadW450);
    EXPECT_TRUE(silent.bytes.empty());
    ASSERT_TRUE(answered.decoded);
    EXPECT_EQ(answered.bytes.size(), 25U);
    EXPECT_NE(sim.command("stats").find("dropped=1 "), std::string::npos);
}

TEST_F(SimLine, LateFault) {
    ASSERT_EQ(sim.command("fault 1 late=30ms").rfind("ok", 0), 0U);
    const auto r = master.transact(kReadFD00);
    ASSERT_TRUE(r.decoded);
    EXPECT_GE(r.byte_times.front() - r.written, minimum_exchange(8, 1, 30ms));
}

TEST(SimLineAt9600, GapFault) {
    // Three character times of silence before byte 4 of the reply.
    SimProcess sim{{"--drive", "2:atv58", "--baud", "9600", "--turnaround", "1ms"}};
    TestMaster master{sim.link(), {9600, 8, rtu::Parity::None, 1}};
    ASSERT_EQ(sim.command("fault 2 gap=4:3").rfind("ok", 0), 0U);
    const auto r = master.transact(kReadW450, 300ms);
    ASSERT_EQ(r.bytes.size(), 25U);
    EXPECT_TRUE(r.decoded);  // the bytes themselves are right
    const auto& t = master.timing();
    const rtu::Duration earliest_byte4 = t.character * 7 + t.t3_5 + kTurnaround + t.character * 8;
    EXPECT_GE(r.byte_times[4] - r.written, earliest_byte4);
    // A master cannot tell a silence on the wire from a delivery the kernel held back, so its
    // framer holds the reply open to its wire bound (first character + 24 characters + t3.5):
    // when the reply's silences add up to no more than t3.5, it completes as a held reply.
    // Whenever this process read byte 3 in time to see the silence (a pty adds the reader's
    // wake-up delay to its timestamps) and the rest came later than the bound allows (a loaded
    // machine stretches what it sees), the frame was broken instead.
    const auto silence = r.byte_times[4] - r.byte_times[3] - t.character;
    if (silence > t.t1_5 && r.reply) {
        EXPECT_TRUE(r.reply->held);
        EXPECT_LE(r.reply->last - r.reply->first, t.character * 24 + t.t3_5) << "completed past its bound";
    } else if (silence > t.t1_5) {
        const bool gap_seen = std::ranges::any_of(r.discarded, [&](const rtu::DiscardedFrame& d) {
            return d.fault == rtu::FrameFault::InterCharacterGap ||
                   (silence > t.t3_5 && d.fault == rtu::FrameFault::CrcMismatch && d.bytes == 4);
        });
        std::string seen;
        for (const auto& d : r.discarded) {
            seen += std::string(rtu::to_string(d.fault)) + " (" + std::to_string(d.bytes) + " bytes); ";
        }
        EXPECT_TRUE(gap_seen) << "discarded: " << seen << "silence before byte 4: " << silence.count() << " ns";
    }
    EXPECT_NE(sim.command("stats").find(" gap=1 "), std::string::npos);
}

TEST_F(SimLine, NoiseFault) {
    ASSERT_EQ(sim.command("fault 1 noise=3:4").rfind("ok", 0), 0U);
    const auto r = master.transact(kReadFD00);
    ASSERT_EQ(r.bytes.size(), 10U);
    // Three noise bytes, then four characters of silence, then the reply.
    ASSERT_TRUE(r.decoded);
    EXPECT_EQ(r.decoded_at, 3U);
    EXPECT_GE(r.byte_times[0] - r.written, minimum_exchange(8, 1));
    EXPECT_GE(r.byte_times[3] - r.written, minimum_exchange(8, 4, master.timing().character * 4));
}

TEST_F(SimLine, EchoFault) {
    ASSERT_EQ(sim.command("fault * echo=1").rfind("ok", 0), 0U);
    const auto request = encoded(kReadFD00);
    const auto r = master.transact(request, kReadFD00);
    ASSERT_GE(r.bytes.size(), request.size() + 7);
    // The request comes back first, then the reply.
    EXPECT_EQ(to_hex(std::vector<std::uint8_t>(r.bytes.begin(), r.bytes.begin() + 8)), to_hex(request));
    ASSERT_TRUE(r.decoded);
    EXPECT_EQ(r.decoded_at, 8U);
    EXPECT_NE(sim.command("stats").find("echoed_bytes=8 "), std::string::npos);
}

TEST_F(SimLine, ExceptionFault) {
    ASSERT_EQ(sim.command("fault 2 exception=4").rfind("ok", 0), 0U);
    const auto r = master.transact(kReadW450);
    ASSERT_TRUE(r.decoded);
    EXPECT_EQ(std::get<rtu::ExceptionResponse>(r.decoded->pdu).code, rtu::ExceptionCode::ServerDeviceFailure);
}

TEST_F(SimLine, CountersOnDemandAndOnExit) {
    ASSERT_TRUE(master.transact(kReadFD00).decoded);
    ASSERT_EQ(sim.command("fault 1 crc=1").rfind("ok", 0), 0U);
    (void)master.transact(kReadFD00, 200ms);
    EXPECT_NE(sim.command("stats").find("crc=1 "), std::string::npos);
    EXPECT_EQ(sim.stop(), 0);
    const std::string out = sim.output();
    EXPECT_NE(out.find("stopped; requests=2 "), std::string::npos) << out;
    EXPECT_NE(out.find(" crc=1 "), std::string::npos) << out;
}

// --device on a tty that is not a pty master (here one end of a pair socat makes, as
// docs/simulator.md suggests; a real UART behaves the same): a raw tty answers a read with 0
// bytes when nothing waits, which is no end of the line. Every request gets its reply.
TEST(SimOnADevice, AnswersEveryRequest) {
    const fs::path dir = fs::temp_directory_path() / ("drivebus-sim-device-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path sim_side = dir / "sim";
    const fs::path master_side = dir / "master";
    Child socat(
        {"/usr/bin/socat", "pty,raw,echo=0,link=" + sim_side.string(), "pty,raw,echo=0,link=" + master_side.string()});
    ASSERT_TRUE(wait_until([&] { return fs::exists(sim_side) && fs::exists(master_side); }, 5s)) << socat.output();
    {
        SimProcess sim(
            {"--device", sim_side.string(), "--drive", "1:atv21", "--parity", "none", "--turnaround", "1ms"});
        EXPECT_EQ(sim.link(), sim_side);
        TestMaster master{master_side, k19200};
        for (int i = 0; i < 5; ++i) {
            const auto r = master.transact(kReadFD00);
            ASSERT_TRUE(r.decoded) << "request " << i << ": read [" << to_hex(r.bytes) << "]; simulator said "
                                   << sim.output();
        }
        EXPECT_NE(sim.command("stats").find("requests=5 "), std::string::npos);
        EXPECT_EQ(sim.stop(), 0) << sim.output();
    }
    socat.stop();
    std::error_code ec;
    fs::remove_all(dir, ec);
}

TEST(SimCommandLine, BadArgumentsAreOneClearLine) {
    const auto [status, out] = run_sim({"--link", "/tmp/never-made", "--drive", "40:atv58"});
    EXPECT_EQ(status, 2);
    EXPECT_NE(out.find("takes addresses 1-31"), std::string::npos) << out;
    const auto [status2, out2] = run_sim({"--link", "/tmp/never-made", "--drive", "1:atv99"});
    EXPECT_EQ(status2, 2);
    EXPECT_NE(out2.find("atv99"), std::string::npos) << out2;
    const auto [status3, out3] = run_sim({"--link", "/tmp/never-made", "--drive", "1:atv21", "--fault", "crc=9"});
    EXPECT_EQ(status3, 2);
    EXPECT_NE(out3.find("share must be between 0 and 1"), std::string::npos) << out3;
    const auto [status4, out4] = run_sim({"--drive", "1:atv21"});
    EXPECT_EQ(status4, 2);
    EXPECT_NE(out4.find("--link or --device"), std::string::npos) << out4;
}

}  // namespace
}  // namespace drivebus::test
