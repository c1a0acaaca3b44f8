// SPDX-License-Identifier: Apache-2.0
// The reaper of locks left held by a killed process, on real process-shared mutexes in shared
// memory like iceoryx's: a child takes one and dies holding it.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <thread>

#include "ipc/held_locks.hpp"

namespace drivebus::ipc {
namespace {

using namespace std::chrono_literals;

// A process-shared recursive mutex, as iceoryx's ThreadSafePolicy makes them, in a shared mapping.
class SharedMutex {
public:
    SharedMutex() {
        void* m = ::mmap(nullptr, sizeof(pthread_mutex_t), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        if (m == MAP_FAILED) {
            throw std::runtime_error("mmap");
        }
        mutex_ = static_cast<pthread_mutex_t*>(m);
        pthread_mutexattr_t attr;
        ::pthread_mutexattr_init(&attr);
        ::pthread_mutexattr_setpshared(&attr, PTHREAD_PROCESS_SHARED);
        ::pthread_mutexattr_settype(&attr, PTHREAD_MUTEX_RECURSIVE_NP);
        ::pthread_mutex_init(mutex_, &attr);
        ::pthread_mutexattr_destroy(&attr);
    }
    ~SharedMutex() { ::munmap(mutex_, sizeof(pthread_mutex_t)); }
    SharedMutex(const SharedMutex&) = delete;
    SharedMutex& operator=(const SharedMutex&) = delete;
    SharedMutex(SharedMutex&&) = delete;
    SharedMutex& operator=(SharedMutex&&) = delete;
    [[nodiscard]] pthread_mutex_t* get() const { return mutex_; }

private:
    pthread_mutex_t* mutex_ = nullptr;
};

// A child that takes the lock (twice: recursively) and is SIGKILLed holding it; returns its pid.
pid_t die_holding(pthread_mutex_t* mutex) {
    int ready[2];
    if (::pipe(ready) != 0) {
        throw std::runtime_error("pipe");
    }
    const pid_t child = ::fork();
    if (child == 0) {
        ::pthread_mutex_lock(mutex);
        ::pthread_mutex_lock(mutex);
        (void)::write(ready[1], "x", 1);
        for (;;) {
            ::pause();
        }
    }
    char c = 0;
    (void)::read(ready[0], &c, 1);
    ::close(ready[0]);
    ::close(ready[1]);
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    return child;
}

// A child killed just after it took the lock word, before glibc wrote its name and the
// recursion count: the lock word is taken as glibc's lock does it (0 to 1), and nothing else.
void die_before_naming_itself(pthread_mutex_t* mutex) {
    const pid_t child = ::fork();
    if (child == 0) {
        int expected = 0;
        (void)std::atomic_ref<int>(mutex->__data.__lock).compare_exchange_strong(expected, 1);
        ::_exit(0);
    }
    ::waitpid(child, nullptr, 0);
}

TEST(HeldLocks, ALockHeldByNobodyIsFreedAfterEnoughSweepsToRuleOutALiveThreadAboutToNameItself) {
    SharedMutex m;
    die_before_naming_itself(m.get());
    EXPECT_TRUE(held(*m.get()));
    EXPECT_EQ(lock_holder(*m.get()), 0);
    EXPECT_EQ(::pthread_mutex_trylock(m.get()), EBUSY);
    HeldLockReaper reaper;
    const std::array locks{m.get()};
    for (int pass = 1; pass < HeldLockReaper::kOwnerlessSweeps; ++pass) {
        EXPECT_EQ(reaper.sweep(locks), 0U) << "pass " << pass;
    }
    EXPECT_EQ(reaper.sweep(locks), 1U);
    EXPECT_FALSE(held(*m.get()));
    ASSERT_EQ(::pthread_mutex_trylock(m.get()), 0);
    EXPECT_EQ(::pthread_mutex_unlock(m.get()), 0);
    EXPECT_EQ(::pthread_mutex_destroy(m.get()), 0);
}

TEST(HeldLocks, ALockThatWasFreeOnePassStartsItsCountAgain) {
    SharedMutex m;
    HeldLockReaper reaper;
    const std::array locks{m.get()};
    die_before_naming_itself(m.get());
    for (int pass = 1; pass < HeldLockReaper::kOwnerlessSweeps; ++pass) {
        EXPECT_EQ(reaper.sweep(locks), 0U);
    }
    // Let go (as a live thread does, a moment after): the count so far no longer counts.
    std::atomic_ref<int>(m.get()->__data.__lock).store(0);
    EXPECT_EQ(reaper.sweep(locks), 0U);
    die_before_naming_itself(m.get());
    for (int pass = 1; pass < HeldLockReaper::kOwnerlessSweeps; ++pass) {
        EXPECT_EQ(reaper.sweep(locks), 0U) << "pass " << pass;
    }
    EXPECT_EQ(reaper.sweep(locks), 1U);
}

TEST(HeldLocks, ALockAKilledProcessHeldIsFreedOnTheSecondSweep) {
    SharedMutex m;
    const pid_t child = die_holding(m.get());
    EXPECT_EQ(lock_holder(*m.get()), child);
    EXPECT_EQ(::pthread_mutex_trylock(m.get()), EBUSY);
    HeldLockReaper reaper;
    const std::array locks{m.get()};
    EXPECT_EQ(reaper.sweep(locks), 0U);  // first seen
    EXPECT_EQ(reaper.sweep(locks), 1U);
    EXPECT_EQ(lock_holder(*m.get()), 0);
    ASSERT_EQ(::pthread_mutex_trylock(m.get()), 0);
    EXPECT_EQ(::pthread_mutex_unlock(m.get()), 0);
    // iceoryx destroys a port's mutex with its port, and aborts when that fails.
    EXPECT_EQ(::pthread_mutex_destroy(m.get()), 0);
}

TEST(HeldLocks, WhatWasSuspectedBeforeForgetDoesNotCount) {
    SharedMutex m;
    (void)die_holding(m.get());
    HeldLockReaper reaper;
    const std::array locks{m.get()};
    EXPECT_EQ(reaper.sweep(locks), 0U);
    reaper.forget();  // a pass refused in between (registrants.hpp)
    EXPECT_EQ(reaper.sweep(locks), 0U);
    EXPECT_NE(lock_holder(*m.get()), 0);
    EXPECT_EQ(reaper.sweep(locks), 1U);
    EXPECT_EQ(lock_holder(*m.get()), 0);
}

TEST(HeldLocks, AThreadWaitingOnTheLockGetsIt) {
    SharedMutex m;
    (void)die_holding(m.get());
    std::atomic<bool> got{false};
    std::thread waiter([&] {
        ::pthread_mutex_lock(m.get());
        got = true;
        ::pthread_mutex_unlock(m.get());
    });
    HeldLockReaper reaper;
    const std::array locks{m.get()};
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (!got && std::chrono::steady_clock::now() < deadline) {
        (void)reaper.sweep(locks);
        std::this_thread::sleep_for(10ms);  // the reaper's period
    }
    EXPECT_TRUE(got);
    if (!got) {
        free_abandoned(*m.get());  // let the waiter end
    }
    waiter.join();
}

TEST(HeldLocks, ALockALiveThreadHoldsIsNeverTaken) {
    SharedMutex m;
    ASSERT_EQ(::pthread_mutex_lock(m.get()), 0);
    HeldLockReaper reaper;
    const std::array locks{m.get()};
    for (int i = 0; i < 5; ++i) {
        EXPECT_EQ(reaper.sweep(locks), 0U);
    }
    EXPECT_EQ(lock_holder(*m.get()), ::gettid());
    EXPECT_EQ(::pthread_mutex_unlock(m.get()), 0);
}

TEST(HeldLocks, AFreeLockHasNoHolder) {
    SharedMutex m;
    EXPECT_EQ(lock_holder(*m.get()), 0);
    HeldLockReaper reaper([](pid_t) { return false; });
    const std::array locks{m.get()};
    EXPECT_EQ(reaper.sweep(locks), 0U);
    EXPECT_EQ(reaper.sweep(locks), 0U);
}

TEST(HeldLocks, AZombieIsNotAlive) {
    const pid_t child = ::fork();
    if (child == 0) {
        ::_exit(0);
    }
    // Not reaped yet: a zombie until waitpid.
    siginfo_t info{};
    ASSERT_EQ(::waitid(P_PID, static_cast<id_t>(child), &info, WEXITED | WNOWAIT), 0);
    EXPECT_FALSE(thread_alive(child));
    ::waitpid(child, nullptr, 0);
    EXPECT_FALSE(thread_alive(child));
    EXPECT_TRUE(thread_alive(::gettid()));
}

}  // namespace
}  // namespace drivebus::ipc
