// SPDX-License-Identifier: Apache-2.0
// Whose thread ids drivebusd can judge: the runtimes RouDi registered, each placed in
// drivebusd's PID namespace or not.
//
// A held iceoryx lock names its holder by thread id, as the holder's own PID namespace numbers
// it (held_locks.hpp). A client in a container that shares /dev/shm and the RouDi socket
// numbers its threads in its own namespace: to drivebusd such an id is unrelated or absent, so
// a live client's lock would look abandoned. The reaper may therefore free a lock only while
// every runtime that could hold one is a process drivebusd sees in its own namespace. A runtime
// registers with the pid it sees for itself; drivebusd judges it (judge_registrant) and, while
// one it cannot place is registered, frees nothing. RouDi's own view decides when such a
// runtime is gone: it said goodbye (TERMINATION), or it has sent no keep-alive for as long as
// RouDi's monitoring waits before it removes a process, while RouDi still heard from others.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>

namespace drivebus::ipc {

// Why the runtime that registered with `pid` and `uid` at `registered_ticks` (clock ticks since
// boot, as /proc/PID/stat counts a start time) cannot be placed in the PID namespace of the
// /proc at `proc`; nullopt when it is the process `pid` there. `sees_all`: whether that /proc
// shows every user's processes (no hidepid, or drivebusd is root).
[[nodiscard]] std::optional<std::string> judge_registrant(pid_t pid, uid_t uid, std::uint64_t registered_ticks,
                                                          const std::filesystem::path& proc, bool sees_all);

// Whether this process's /proc shows every user's processes: it is root, or /proc is mounted
// without hidepid (systemd's ProtectProc=invisible, noaccess and ptraceable set it).
[[nodiscard]] bool proc_shows_everyone();

// Clock ticks since boot now, as /proc/PID/stat counts a start time.
[[nodiscard]] std::uint64_t boot_ticks_now();

// A runtime that keeps freeing from being safe, and why.
struct Refusal {
    std::string runtime;
    pid_t pid = 0;
    std::string reason;
    friend bool operator==(const Refusal&, const Refusal&) = default;
};

// The runtimes RouDi registered, told by RouDi's message thread; asked by the reaper's.
class Registrants {
public:
    using Clock = std::chrono::steady_clock;

    // `silence`: how long RouDi waits for a keep-alive before it takes a runtime for gone.
    explicit Registrants(Clock::duration silence) : silence_(silence) {}

    // A registration (REG) with judge_registrant's verdict (taken while the runtime waits for
    // RouDi's answer, so alive), a keep-alive or other message, and a goodbye (TERMINATION).
    void registered(const std::string& runtime, pid_t pid, std::optional<std::string> why_not_placed,
                    Clock::time_point now);
    void heard(const std::string& runtime, Clock::time_point now);
    void left(const std::string& runtime);

    // Forgets the runtimes RouDi takes for gone (no message for `silence` while others' came),
    // and returns the first of the others that could not be placed: while there is one, no lock
    // may be freed.
    [[nodiscard]] std::optional<Refusal> refusal();

    [[nodiscard]] std::size_t size() const;

private:
    struct Entry {
        pid_t pid = 0;
        std::optional<std::string> why_not_placed;
        Clock::time_point heard;
    };
    Clock::duration silence_;
    mutable std::mutex mutex_;
    std::map<std::string, Entry> entries_;
    Clock::time_point latest_{};  // the last message heard from anyone
};

}  // namespace drivebus::ipc
