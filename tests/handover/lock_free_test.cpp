// SPDX-License-Identifier: Apache-2.0
// The bus thread shares no lock with the ipc thread by construction: what they share is the
// hand-over (rings, eventfds, atomics, a seqlock). This reads the sources of everything on
// that boundary and fails if one of them takes up a lock, so that a mutex cannot creep back
// in unnoticed.
#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <sstream>
#include <string>

namespace drivebus::test {
namespace {

std::string read(const std::string& path) {
    std::ifstream in(std::string(DRIVEBUS_SOURCE_DIR) + "/" + path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

TEST(LockFree, NothingBetweenTheBusThreadAndTheIpcThreadTakesALock) {
    const std::array files = {
        "daemon/bus/include/bus/bus_loop.hpp",
        "daemon/bus/bus_loop.cpp",
        "daemon/bus/include/bus/handover.hpp",
        "daemon/bus/handover.cpp",
        "daemon/master/include/master/finished.hpp",
        "daemon/bus/include/bus/desk.hpp",
        "daemon/bus/desk.cpp",
        "lib/sys/include/sys/spsc_ring.hpp",
        "lib/sys/include/sys/seqlock.hpp",
        "daemon/ipc/include/ipc/bus_service.hpp",
        "daemon/ipc/bus_service.cpp",
        "daemon/ipc/include/ipc/intake.hpp",
        "daemon/ipc/intake.cpp",
        "daemon/ipc_core/include/ipc/intake_core.hpp",
        "daemon/ipc_core/intake_core.cpp",
        "daemon/ipc_core/include/ipc/pending.hpp",
        "daemon/ipc_core/pending.cpp",
        "daemon/ipc/include/ipc/publisher.hpp",
        "daemon/ipc/publisher.cpp",
    };
    // iceoryx's UserTrigger takes a mutex on trigger(): the bus thread wakes the ipc side
    // through an eventfd instead.
    const std::array forbidden = {"std::mutex",   "lock_guard",         "unique_lock", "scoped_lock",
                                  "shared_mutex", "condition_variable", "UserTrigger", "std::promise"};
    for (const auto* file : files) {
        const std::string text = read(file);
        ASSERT_FALSE(text.empty()) << file;
        for (const auto* word : forbidden) {
            // bus_loop.cpp's start-up hand-shake (a promise, before the loop runs) is allowed.
            if (std::string(word) == "std::promise" && std::string(file) == "daemon/bus/bus_loop.cpp") {
                continue;
            }
            EXPECT_EQ(text.find(word), std::string::npos) << file << " uses " << word;
        }
    }
}

}  // namespace
}  // namespace drivebus::test
