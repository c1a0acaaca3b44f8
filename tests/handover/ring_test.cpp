// SPDX-License-Identifier: Apache-2.0
// The lock-free pieces between the bus thread and the threads below it: the SPSC ring (order,
// a full ring, wrap-around, one producer and one consumer on two threads) and the seqlock (no
// reader ever sees a half-written value).
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

#include "sys/seqlock.hpp"
#include "sys/spsc_ring.hpp"

namespace drivebus::test {
namespace {

TEST(SpscRing, AFullRingRefusesThePushAndKeepsWhatItHas) {
    sys::SpscRing<int> ring(3);
    EXPECT_TRUE(ring.try_push(1));
    EXPECT_TRUE(ring.try_push(2));
    EXPECT_TRUE(ring.try_push(3));
    EXPECT_FALSE(ring.try_push(4)) << "a full ring must refuse, never overwrite";
    EXPECT_EQ(ring.size(), 3U);
    int v = 0;
    for (const int expected : {1, 2, 3}) {
        ASSERT_TRUE(ring.try_pop(v));
        EXPECT_EQ(v, expected);
    }
    EXPECT_FALSE(ring.try_pop(v));
    EXPECT_TRUE(ring.try_push(5)) << "room again once the consumer took an entry";
}

TEST(SpscRing, WrapsAroundItsSlotsInOrder) {
    sys::SpscRing<std::uint64_t> ring(5);
    std::uint64_t next_in = 0;
    std::uint64_t next_out = 0;
    // Uneven pushes and pops move the ends through every slot many times.
    for (int round = 0; round < 1000; ++round) {
        for (int i = 0; i < 1 + round % 5; ++i) {
            if (ring.try_push(next_in)) {
                ++next_in;
            }
        }
        std::uint64_t v = 0;
        for (int i = 0; i < 1 + (round * 7) % 5 && ring.try_pop(v); ++i) {
            ASSERT_EQ(v, next_out);
            ++next_out;
        }
    }
    EXPECT_GT(next_out, 1000U);
    EXPECT_EQ(ring.size(), next_in - next_out);
}

struct Entry {
    std::uint64_t sequence = 0;
    std::array<std::uint64_t, 7> copies{};  // each equal to sequence: a torn entry shows
};

TEST(SpscRing, OneProducerAndOneConsumerOnTwoThreadsLoseAndReorderNothing) {
    constexpr std::uint64_t kCount = 1'000'000;
    sys::SpscRing<Entry> ring(64);
    std::atomic<std::uint64_t> refused{0};
    std::thread producer([&] {
        for (std::uint64_t i = 0; i < kCount;) {
            Entry e;
            e.sequence = i;
            e.copies.fill(i);
            if (ring.try_push(e)) {
                ++i;
            } else {
                refused.fetch_add(1, std::memory_order_relaxed);
                std::this_thread::yield();
            }
        }
    });
    std::uint64_t expected = 0;
    std::uint64_t bad = 0;
    while (expected < kCount) {
        Entry e;
        if (!ring.try_pop(e)) {
            std::this_thread::yield();
            continue;
        }
        bad += e.sequence != expected ? 1 : 0;
        for (const auto c : e.copies) {
            bad += c != e.sequence ? 1 : 0;
        }
        ++expected;
    }
    producer.join();
    EXPECT_EQ(bad, 0U);
    Entry rest;
    EXPECT_FALSE(ring.try_pop(rest));
}

struct Wide {
    std::array<std::uint64_t, 40> words{};
};

TEST(Seqlock, NoReaderSeesAHalfWrittenValue) {
    sys::Seqlock<Wide> lock;
    std::atomic<bool> done{false};
    std::atomic<std::uint64_t> torn{0};
    std::atomic<std::uint64_t> reads{0};
    std::vector<std::thread> readers;
    for (int r = 0; r < 2; ++r) {
        readers.emplace_back([&] {
            std::uint64_t last = 0;
            while (!done.load()) {
                const Wide w = lock.load();
                for (const auto x : w.words) {
                    torn += x != w.words[0] ? 1 : 0;
                }
                torn += w.words[0] < last ? 1 : 0;  // never back in time
                last = w.words[0];
                reads.fetch_add(1, std::memory_order_relaxed);
            }
        });
    }
    for (std::uint64_t i = 1; i <= 200'000; ++i) {
        Wide w;
        w.words.fill(i);
        lock.store(w);
    }
    done = true;
    for (auto& t : readers) {
        t.join();
    }
    EXPECT_EQ(torn.load(), 0U);
    EXPECT_GT(reads.load(), 0U);
    EXPECT_EQ(lock.load().words[39], 200'000U);
}

}  // namespace
}  // namespace drivebus::test
