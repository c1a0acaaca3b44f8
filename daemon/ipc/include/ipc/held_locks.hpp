// SPDX-License-Identifier: Apache-2.0
// Locks that a killed process left held in iceoryx's shared memory, freed.
//
// iceoryx 2.0 guards each port's queue and distributor with a process-shared, recursive pthread
// mutex that is not robust. A client SIGKILLed inside send() keeps its own distributor's lock,
// and often the lock of the server's request queue it was pushing into, for good: every other
// client's send() then waits on it, and so does RouDi's clean-up of the dead client (its
// monitoring thread, then every runtime's registration behind it). iceoryx 2.0 knows
// ("CHUNK_DISTRIBUTOR_CLEANUP_DEADLOCK_BECAUSE_BAD_APPLICATION_TERMINATION") and offers no cure.
//
// The mutexes are glibc's: a held one names its owner thread. A lock whose owner thread has
// ended, seen so on two sweeps in a row, is handed back as that thread's unlock would have
// done, and its waiters are woken. glibc takes the lock word first and writes the owner's name
// (and the recursion count) just after: a client killed between the two leaves a lock held by
// nobody, which no live thread shows for longer than those few instructions; seen so on
// kOwnerlessSweeps sweeps in a row, it is handed back too. Only the process that holds RouDi
// (an embedded RouDi) can reach every port; an external iox-roudi gets no such help. The
// thread id is the holder's PID namespace's: drivebusd sweeps only while every registered
// runtime is in its own (registrants.hpp).
#pragma once

#include <pthread.h>
#include <sys/types.h>

#include <cstddef>
#include <functional>
#include <map>
#include <span>
#include <vector>

namespace iox::roudi {
class PortPool;
}

namespace drivebus::ipc {

// Whether thread `tid` exists and has not ended (a zombie has). In doubt (its /proc entry
// hidden), alive.
[[nodiscard]] bool thread_alive(pid_t tid);

// Whether `mutex`'s lock word is taken.
[[nodiscard]] bool held(const pthread_mutex_t& mutex);
// The holder of `mutex` when it is held and names one; 0 otherwise.
[[nodiscard]] pid_t lock_holder(const pthread_mutex_t& mutex);

// Frees `mutex`, held by a thread that has ended: what its unlock would have done (owner,
// recursion count and users cleared, the lock word released), then wakes every waiter.
void free_abandoned(pthread_mutex_t& mutex);

class HeldLockReaper {
public:
    using Alive = std::function<bool(pid_t)>;
    explicit HeldLockReaper(Alive alive = thread_alive) : alive_(std::move(alive)) {}

    // Sweeps in a row that find a lock held by no thread before it is freed: at the reaper's
    // 100 ms, 0.4 s and more, against the few instructions a live thread spends so.
    static constexpr int kOwnerlessSweeps = 5;

    // One pass over `locks`: frees those held by the same ended thread as on the last pass, and
    // those held by nobody on the last kOwnerlessSweeps passes. Returns how many it freed.
    std::size_t sweep(std::span<pthread_mutex_t* const> locks);

    // Forgets what the last pass suspected: the next pass starts afresh.
    void forget() { suspects_.clear(); }

private:
    Alive alive_;
    struct Seen {
        pid_t holder = 0;  // 0: nobody
        int times = 0;     // passes in a row
    };
    std::map<const pthread_mutex_t*, Seen> suspects_;  // held by an ended thread or nobody
};

// Every lock of every port RouDi's port pool holds (clients, servers, publishers, subscribers).
[[nodiscard]] std::vector<pthread_mutex_t*> port_locks(iox::roudi::PortPool& pool);

}  // namespace drivebus::ipc
