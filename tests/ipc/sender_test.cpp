// SPDX-License-Identifier: Apache-2.0
// libdrivebus's sender: requests reach iceoryx on a thread of their own, so that a send() that
// iceoryx holds up (a lock a killed process left held) holds up no caller, and what has not
// reached iceoryx yet can be taken back.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "sender.hpp"

namespace drivebus {
namespace {

using namespace std::chrono_literals;

shm::Request numbered(std::uint64_t correlation) {
    shm::Request r;
    r.correlation = correlation;
    return r;
}

// What the sender reported, for the test to wait on.
struct Reports {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<std::pair<std::uint64_t, bool>> done;
    Sender::Done callback() {
        return [this](const shm::Request& r, bool sent) {
            {
                const std::lock_guard lock(mutex);
                done.emplace_back(r.correlation, sent);
            }
            changed.notify_all();
        };
    }
    bool wait_for(std::size_t n) {
        std::unique_lock lock(mutex);
        return changed.wait_for(lock, 10s, [&] { return done.size() >= n; });
    }
};

// A hand-over that blocks until opened, as iceoryx's send() does on a lock nobody frees.
struct Gate {
    std::mutex mutex;
    std::condition_variable changed;
    bool open = false;
    bool entered = false;
    void pass() {
        std::unique_lock lock(mutex);
        entered = true;
        changed.notify_all();
        changed.wait(lock, [&] { return open; });
    }
    bool wait_entered() {
        std::unique_lock lock(mutex);
        return changed.wait_for(lock, 10s, [&] { return entered; });
    }
    void release() {
        {
            const std::lock_guard lock(mutex);
            open = true;
        }
        changed.notify_all();
    }
};

TEST(Sender, HandsRequestsOverInOrderAndSaysSo) {
    Reports reports;
    std::atomic<int> refused_at{2};
    Sender sender([&](const shm::Request& r) { return static_cast<int>(r.correlation) != refused_at; },
                  reports.callback());
    for (std::uint64_t i = 1; i <= 3; ++i) {
        sender.post(numbered(i));
    }
    ASSERT_TRUE(reports.wait_for(3));
    const std::vector<std::pair<std::uint64_t, bool>> want = {{1, true}, {2, false}, {3, true}};
    const std::lock_guard lock(reports.mutex);
    EXPECT_EQ(reports.done, want);
    EXPECT_FALSE(sender.stop());
}

TEST(Sender, ASendIceoryxHoldsUpHoldsUpNoCallerAndTheRestCanBeTakenBack) {
    auto gate = std::make_shared<Gate>();
    Reports reports;
    auto sender = std::make_unique<Sender>(
        [gate](const shm::Request& r) {
            if (r.correlation == 1) {
                gate->pass();
            }
            return true;
        },
        reports.callback());
    sender->post(numbered(1));
    ASSERT_TRUE(gate->wait_entered());
    sender->post(numbered(2));          // returns at once although the sender is held up
    EXPECT_TRUE(sender->withdraw(2));   // never reached iceoryx: it never will
    EXPECT_FALSE(sender->withdraw(1));  // inside iceoryx: not to be taken back
    EXPECT_FALSE(sender->withdraw(2));
    EXPECT_TRUE(sender->stop());  // the port must be left to the send() under way
    sender.reset();
    gate->release();  // iceoryx lets go at last: nobody is told any more
    // The thread ends (its state, with the hand-over and this gate, goes) without a word.
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (gate.use_count() > 1 && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::yield();
    }
    EXPECT_EQ(gate.use_count(), 1);
    const std::lock_guard lock(reports.mutex);
    EXPECT_TRUE(reports.done.empty());
}

}  // namespace
}  // namespace drivebus
