// SPDX-License-Identifier: Apache-2.0
// Control under a flood of readers, as processes: six clients keep 12 reads each in flight
// (iceoryx directly), more than the whole queue; a controller starting meanwhile takes the
// pump's lease and commands it at its first try, and the drive runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "client_process.hpp"
#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

TEST(Ipc, AControllerTakesTheLeaseAtOnceWhileReadersFlood) {
    StackOptions options;
    options.paced = false;
    Stack stack(options);
    std::vector<std::unique_ptr<Client>> readers;
    for (int i = 0; i < 6; ++i) {
        readers.push_back(
            std::make_unique<Client>(std::vector<std::string>{stack.bus(), "keep", "12"}, RAW_REQUEST_PATH));
    }
    for (auto& r : readers) {
        ASSERT_TRUE(r->printed("flooding", 30s)) << r->output();
    }
    // 72 reads against the queue: some readers are being told it is full.
    ASSERT_TRUE(wait_until(
        [&] {
            return std::ranges::any_of(readers, [](auto& r) {
                const auto& out = r->output();
                const auto at = out.rfind(" full ");
                return at != std::string::npos && std::stoul(out.substr(at + 6)) > 0;
            });
        },
        60s));
    for (int round = 0; round < 3; ++round) {
        Client controller({stack.bus(), "take", "20"});
        ASSERT_EQ(controller.wait(30s), 0) << controller.output() << "\n" << stack.daemon_output();
        EXPECT_NE(controller.output().find("took tries 1 "), std::string::npos) << controller.output();
        std::printf("round %d: %s", round, controller.output().c_str());
        EXPECT_EQ(stack.sim_register(1, "FA00"), 0xC400);
        EXPECT_EQ(stack.sim_register(1, "FA01"), 2000);
    }
}

// A raw client that writes another client id in each of its 16 reads is one port all the same,
// so one share of the queue (12 of the 64): the reads past it are answered QueueFull. Before,
// each id had a share of its own, and all 16 were booked. The pump answers each read 80 ms late
// (within drivebusd's time-out), so that every read booked stays in flight while the flood is
// taken; a controller then takes the lease at its first try.
TEST(Ipc, AClientThatChangesItsIdWithEachRequestHasOneShareOfTheQueue) {
    StackOptions options;
    options.polls = false;
    Stack stack(options);
    ASSERT_EQ(stack.sim().command("fault 1 late=80ms").rfind("ok ", 0), 0U) << stack.sim().output();
    Client rotating({stack.bus(), "rotate", "16"}, RAW_REQUEST_PATH);
    ASSERT_EQ(rotating.wait(60s), 0) << rotating.output() << "\n" << stack.daemon_output();
    const auto& out = rotating.output();
    const auto at = out.find(" full ");
    ASSERT_NE(at, std::string::npos) << out;
    const auto full = std::stoi(out.substr(at + 6));
    EXPECT_GE(full, 1) << out;
    EXPECT_LE(full, 4) << out << " (a share is 12 of 16)";
    ASSERT_EQ(stack.sim().command("clear 1").rfind("ok", 0), 0U);
    Client controller({stack.bus(), "take", "20"});
    ASSERT_EQ(controller.wait(30s), 0) << controller.output() << "\n" << stack.daemon_output();
    EXPECT_NE(controller.output().find("took tries 1 "), std::string::npos) << controller.output();
}

}  // namespace
}  // namespace drivebus::test
