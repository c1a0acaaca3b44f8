// SPDX-License-Identifier: Apache-2.0
#include "ipc/held_locks.hpp"

#include <linux/futex.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <fstream>
#include <string>
#include <type_traits>

#include "iceoryx_posh/roudi/port_pool.hpp"

namespace drivebus::ipc {
namespace {

// ThreadSafePolicy holds its posix::mutex and nothing else, and posix::mutex its pthread_mutex_t.
static_assert(sizeof(iox::popo::ThreadSafePolicy) == sizeof(pthread_mutex_t));
static_assert(std::is_standard_layout_v<pthread_mutex_t>);

template <typename Guarded>
void add(std::vector<pthread_mutex_t*>& out, Guarded& guarded) {
    if constexpr (std::is_base_of_v<iox::popo::ThreadSafePolicy, Guarded>) {
        auto& policy = static_cast<iox::popo::ThreadSafePolicy&>(guarded);
        out.push_back(reinterpret_cast<pthread_mutex_t*>(&policy));
    }
}

}  // namespace

bool thread_alive(pid_t tid) {
    // kill() takes any thread id and says ESRCH only when it is gone; EPERM (another user's
    // process) means it exists. /proc may hide other users' processes (the units' ProtectProc=
    // invisible), so it is only asked whether a thread that exists has ended as a zombie.
    if (::kill(tid, 0) != 0 && errno == ESRCH) {
        return false;
    }
    std::ifstream stat("/proc/" + std::to_string(tid) + "/stat");
    std::string text;
    if (!std::getline(stat, text)) {
        return true;  // hidden or unreadable: alive, never free a live thread's lock
    }
    const auto paren = text.rfind(')');
    if (paren == std::string::npos || paren + 2 >= text.size()) {
        return true;
    }
    const char state = text[paren + 2];
    return state != 'Z' && state != 'X' && state != 'x';
}

bool held(const pthread_mutex_t& mutex) {
    return std::atomic_ref<const int>(mutex.__data.__lock).load(std::memory_order_acquire) != 0;
}

pid_t lock_holder(const pthread_mutex_t& mutex) {
    const auto& data = mutex.__data;
    const int word = std::atomic_ref<const int>(data.__lock).load(std::memory_order_acquire);
    if (word == 0) {
        return 0;
    }
    return std::atomic_ref<const int>(data.__owner).load(std::memory_order_relaxed);
}

void free_abandoned(pthread_mutex_t& mutex) {
    auto& data = mutex.__data;
    // The owner's fields first, while the lock word still keeps every waiter out.
    data.__count = 0;
    data.__nusers = 0;  // glibc counts the holder here; destroying the mutex checks it is 0
    std::atomic_ref<int>(data.__owner).store(0, std::memory_order_relaxed);
    std::atomic_ref<int>(data.__lock).store(0, std::memory_order_release);
    // A shared futex (the mutex is process-shared): wake them all, one of them takes it.
    (void)::syscall(SYS_futex, &data.__lock, FUTEX_WAKE, INT_MAX, nullptr, nullptr, 0);
}

std::size_t HeldLockReaper::sweep(std::span<pthread_mutex_t* const> locks) {
    std::map<const pthread_mutex_t*, Seen> suspects;
    std::size_t freed = 0;
    for (auto* lock : locks) {
        if (!held(*lock)) {
            continue;
        }
        const pid_t holder = lock_holder(*lock);
        if (holder < 0 || (holder > 0 && alive_(holder))) {
            continue;
        }
        // The same ended thread twice in a row: nobody is about to let go of it. No holder at
        // all, kOwnerlessSweeps times in a row: one died between taking the lock word and
        // writing its name (a window of a few instructions, which a live thread leaves at once).
        const auto it = suspects_.find(lock);
        const int times = it != suspects_.end() && it->second.holder == holder ? it->second.times + 1 : 1;
        if (times >= (holder == 0 ? kOwnerlessSweeps : 2)) {
            if (held(*lock) && lock_holder(*lock) == holder) {
                free_abandoned(*lock);
                ++freed;
            }
            continue;
        }
        suspects.emplace(lock, Seen{holder, times});
    }
    suspects_ = std::move(suspects);
    return freed;
}

std::vector<pthread_mutex_t*> port_locks(iox::roudi::PortPool& pool) {
    std::vector<pthread_mutex_t*> out;
    for (auto* port : pool.getClientPortDataList()) {
        add(out, port->m_chunkSenderData);
        add(out, port->m_chunkReceiverData);
    }
    for (auto* port : pool.getServerPortDataList()) {
        add(out, port->m_chunkSenderData);
        add(out, port->m_chunkReceiverData);
    }
    for (auto* port : pool.getPublisherPortDataList()) {
        add(out, port->m_chunkSenderData);
    }
    for (auto* port : pool.getSubscriberPortDataList()) {
        add(out, port->m_chunkReceiverData);
    }
    return out;
}

}  // namespace drivebus::ipc
