// SPDX-License-Identifier: Apache-2.0
// drivebusd's bus thread against a slave nobody here wrote: libmodbus's RTU server, on a pty
// pair made by socat. Reads and writes must land.
#include <gtest/gtest.h>

#include <filesystem>
#include <mutex>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

TEST(IndependentSlave, ReadsAndWritesLandOnALibmodbusSlave) {
    const fs::path dir = fs::temp_directory_path() / ("drivebus-libmodbus-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path master_side = dir / "master";
    const fs::path slave_side = dir / "slave";
    Child socat({"/usr/bin/socat", "pty,raw,echo=0,link=" + master_side.string(),
                 "pty,raw,echo=0,link=" + slave_side.string()});
    ASSERT_TRUE(wait_until([&] { return fs::exists(master_side) && fs::exists(slave_side); }, 5s)) << socat.output();
    Child slave({LIBMODBUS_SLAVE_PATH, slave_side.string(), "7"});
    ASSERT_TRUE(wait_until([&] { return slave.output().find("ready") != std::string::npos; }, 5s)) << slave.output();

    config::BusConfig config = bus<config::BusConfig>();
    config.device = master_side;
    config.response_timeout = 200ms;
    auto generic = load("generic");
    auto d = drive("slave", 7, generic);
    config::PollGroup g;
    g.name = "all";
    g.period = 50ms;
    for (std::uint16_t a = 0; a < 10; ++a) {
        g.registers.push_back({"0x000" + std::to_string(a), a});
    }
    d.polls.push_back(g);
    config.drives.push_back(d);

    std::mutex mutex;
    std::optional<master::DriveSnapshot> latest;
    std::map<std::uint64_t, master::Result> results;
    master::EngineCallbacks callbacks;
    callbacks.snapshot = [&](const master::DriveSnapshot& s) {
        const std::lock_guard lock(mutex);
        latest = s;
    };
    callbacks.client_result = [&](std::uint64_t id, const master::Result& r) {
        const std::lock_guard lock(mutex);
        results[id] = r;
    };
    bus::BusLoop loop(config, callbacks);
    ASSERT_TRUE(loop.start().has_value());
    auto value = [&](std::uint16_t a) -> std::optional<std::uint16_t> {
        const std::lock_guard lock(mutex);
        if (!latest || !latest->registers.contains(a) || !latest->registers.at(a).valid) {
            return std::nullopt;
        }
        return latest->registers.at(a).value;
    };

    // Reads: the slave's registers start at 1000 + i.
    ASSERT_TRUE(wait_until([&] { return value(9) == 1009; }, 10s)) << slave.output();
    for (std::uint16_t a = 0; a < 10; ++a) {
        EXPECT_EQ(value(a), 1000 + a);
    }
    // Writes: FC06 and FC16, then read back through the polls.
    ASSERT_TRUE(loop.submit({1, 100, {7, rtu::WriteSingleRegister{3, 4242}}}).has_value());
    ASSERT_TRUE(loop.submit({1, 101, {7, rtu::WriteMultipleRegisters{5, {11, 22, 33}}}}).has_value());
    ASSERT_TRUE(wait_until(
        [&] {
            const std::lock_guard lock(mutex);
            return results.size() == 2;
        },
        10s));
    EXPECT_EQ(results[100].outcome, master::Outcome::Ok);
    EXPECT_EQ(results[101].outcome, master::Outcome::Ok);
    EXPECT_TRUE(wait_until([&] { return value(3) == 4242 && value(5) == 11 && value(7) == 33; }, 10s));
    // An exception from the slave: register 200 does not exist.
    ASSERT_TRUE(loop.submit({1, 102, {7, rtu::ReadHoldingRegisters{200, 1}}}).has_value());
    ASSERT_TRUE(wait_until(
        [&] {
            const std::lock_guard lock(mutex);
            return results.contains(102);
        },
        10s));
    EXPECT_EQ(results[102].exception(), rtu::ExceptionCode::IllegalDataAddress);
    loop.stop();

    // The slave's own account of what was written.
    EXPECT_EQ(slave.stop(), 0);
    const std::string written = slave.output();
    EXPECT_NE(written.find("reg 3 = 4242"), std::string::npos) << written;
    EXPECT_NE(written.find("reg 5 = 11"), std::string::npos) << written;
    EXPECT_NE(written.find("reg 6 = 22"), std::string::npos) << written;
    EXPECT_NE(written.find("reg 7 = 33"), std::string::npos) << written;
    EXPECT_EQ(loop.status().counters.crc_errors, 0U);
    socat.stop();
    std::error_code ec;
    fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace drivebus::test
