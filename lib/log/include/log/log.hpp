// SPDX-License-Identifier: Apache-2.0
// Logging for drivebusd: one line per message on stderr, with the syslog priority prefix
// ("<4>") that journald reads when stderr is the journal, so levels survive without a
// library; repeats of the same fault are rate-limited (logged once, then counted).
//
// A thread that must never wait (a real-time bus thread) does not write itself: it is given a
// Ring, and its lines go into that lock-free ring, which the log's own thread drains and
// writes. A full ring drops the line and counts it; the count is logged with the next line.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

#include "sys/spsc_ring.hpp"

namespace drivebus::log {

enum class Level : std::uint8_t { Error = 3, Warning = 4, Notice = 5, Info = 6, Debug = 7 };

// Journal prefixes when stderr is connected to the journal (JOURNAL_STREAM), plain
// "drivebusd: warning: ..." otherwise. Messages above `max` are dropped.
void init(std::string_view program, Level max);
void write(Level level, std::string_view message);
// `message` as it is printed: control characters (a newline, an escape sequence) become \xNN,
// so that text from outside (a client's name, a path) can neither start a forged line of the
// journal nor move the terminal's cursor. Clean text comes back unchanged.
[[nodiscard]] std::string one_line(std::string_view message);
// Whether a message at `level` would be written (check before building an expensive one).
[[nodiscard]] bool enabled(Level level) noexcept;

// One line in a Ring: fixed size, truncated.
struct RingLine {
    Level level = Level::Info;
    std::uint16_t length = 0;
    std::array<char, 256> text{};
};

// A thread's log ring. Create it on a thread that may wait (it registers with the log's
// drain thread), then call use_on_this_thread() on the thread that must not; destroy it after
// that thread has ended (what is left in it is written first).
class Ring {
public:
    // `drained` false: not given to the drain thread; the owner calls drain() (tests).
    explicit Ring(std::size_t capacity = 256, bool drained = true);
    ~Ring();
    Ring(const Ring&) = delete;
    Ring& operator=(const Ring&) = delete;
    Ring(Ring&&) = delete;
    Ring& operator=(Ring&&) = delete;

    // From now on, log lines of the calling thread go into this ring.
    void use_on_this_thread() noexcept;
    // The producer side (the thread using it): false when full (the line is counted dropped).
    bool put(Level level, std::string_view message) noexcept;
    // The consumer side (the drain thread, or the owner of an undrained ring): writes what is
    // waiting.
    void drain();

    [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

private:
    sys::SpscRing<RingLine> lines_;
    std::atomic<std::uint64_t> dropped_{0};
    std::uint64_t dropped_reported_ = 0;
    bool drained_;
};

inline void error(std::string_view m) {
    write(Level::Error, m);
}
inline void warning(std::string_view m) {
    write(Level::Warning, m);
}
inline void notice(std::string_view m) {
    write(Level::Notice, m);
}
inline void info(std::string_view m) {
    write(Level::Info, m);
}
inline void debug(std::string_view m) {
    write(Level::Debug, m);
}

// A fault that repeats (a slave timing out every poll) is logged the first time, then once
// per interval with the number of repeats in between.
class RateLimited {
public:
    explicit RateLimited(std::chrono::seconds interval = std::chrono::seconds(60)) : interval_(interval) {}
    void write(Level level, const std::string& key, std::string_view message);
    // The condition is over: the next occurrence is logged at once.
    void reset(const std::string& key);

private:
    struct Entry {
        std::chrono::steady_clock::time_point last{};
        std::uint64_t suppressed = 0;
    };
    std::chrono::seconds interval_;
    std::mutex mutex_;
    std::map<std::string, Entry> entries_;
};

}  // namespace drivebus::log
