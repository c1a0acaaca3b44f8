// SPDX-License-Identifier: Apache-2.0
// Logging for drivebusd. When stderr is the journal (systemd says so in JOURNAL_STREAM), each
// message goes to journald through its native protocol (sd_journal_sendv) with structured
// fields: MESSAGE, PRIORITY, SYSLOG_IDENTIFIER, BUS and DRIVE when the message concerns one,
// CODE_FILE, CODE_LINE and CODE_FUNC. Otherwise, or if journald refuses a message, one line
// per message on stderr ("drivebusd: warning: ...", or "<4>..." when stderr is the journal).
// Repeats of the same fault are rate-limited (logged once, then counted).
//
// A thread that must never wait (a real-time bus thread) does not write itself: it is given a
// Ring, and its lines go into that lock-free ring, which the log's own thread drains and
// writes. A full ring drops the line and counts it; the count is logged with the next line.
#pragma once

#include <sys/uio.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <source_location>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sys/spsc_ring.hpp"

namespace drivebus::log {

enum class Level : std::uint8_t { Error = 3, Warning = 4, Notice = 5, Info = 6, Debug = 7 };

// What a message concerns, for the journal's BUS= and DRIVE= fields (journalctl BUS=line1).
// The views must stay valid while the call lasts (a thread's fields: while they are set). The
// message text names them too: the fields are for filtering, the text for reading.
struct Fields {
    std::string_view bus{};
    std::string_view drive{};
};

// One message as the sinks see it.
struct Entry {
    Level level = Level::Info;
    std::string_view message;
    Fields fields;
    std::source_location where;
};

// Chooses the sink from the environment: the journal when JOURNAL_STREAM names stderr's device
// and inode, stderr otherwise. Messages above `max` are dropped.
void init(std::string_view program, Level max);
// `where` is filled in by the compiler at the call: the journal's CODE_FILE, CODE_LINE and
// CODE_FUNC.
void write(Level level, std::string_view message, const Fields& fields = {},
           std::source_location where = std::source_location::current());
// `message` as it is printed: control characters (a newline, an escape sequence) become \xNN,
// so that text from outside (a client's name, a path) can neither start a forged line of the
// journal nor move the terminal's cursor. Clean text comes back unchanged.
[[nodiscard]] std::string one_line(std::string_view message);
// Whether a message at `level` would be written (check before building an expensive one).
[[nodiscard]] bool enabled(Level level) noexcept;

// From now on, whatever other code writes on std::cout, std::clog and std::cerr goes through
// this log a line at a time, without escapes (log/stream_lines.hpp): iceoryx's messages at
// their own priority, with "iceoryx: " before them; iceoryx's failed system calls and other
// std::cerr lines as warnings; other std::clog and std::cout lines (iceoryx's shared memory
// set-up, its RouDi's "RouDi is ready for clients") at debug. Nothing reaches stdout through
// them any more: call it once the command line's own output (--version, --check-config) is out.
void route_standard_streams();

// Whether stderr is the journal: `journal_stream` (JOURNAL_STREAM, "DEVICE:INODE" in decimal,
// which systemd sets for a unit whose stdout or stderr it connects to the journal) names the
// device and inode of stderr. Null or malformed: false.
[[nodiscard]] bool is_journal_stream(const char* journal_stream, std::uint64_t device, std::uint64_t inode) noexcept;
// The journal fields of `entry`, "NAME=value" each: MESSAGE (one line, as one_line() makes it),
// PRIORITY, SYSLOG_IDENTIFIER, then BUS and DRIVE when not empty, CODE_FILE (without leading
// "../" and "./"), CODE_LINE and CODE_FUNC when known. Values other than MESSAGE are kept as they are (the native
// protocol carries newlines).
[[nodiscard]] std::vector<std::string> journal_fields(std::string_view program, const Entry& entry);

// Where the lines go in the end. The default sends to journald and prints on stderr; a test
// puts its own in to see what would go where.
class Backend {
public:
    Backend() = default;
    virtual ~Backend() = default;
    Backend(const Backend&) = delete;
    Backend& operator=(const Backend&) = delete;
    Backend(Backend&&) = delete;
    Backend& operator=(Backend&&) = delete;
    // As sd_journal_sendv: 0 when journald took the fields, a negative errno when not.
    virtual int send(std::span<const iovec> fields) noexcept = 0;
    // One line with its newline, on stderr.
    virtual void print(std::string_view line) noexcept = 0;
};
// `backend` (nullptr: the default) from now on; takes effect for the sink init() chooses.
void set_backend(Backend* backend) noexcept;
// Whether init() chose the journal.
[[nodiscard]] bool to_journal() noexcept;

// While it lives, the lines the calling thread writes carry `fields` where the call gives none
// (a bus thread always logs for its bus: it sets BUS once).
class ThreadFields {
public:
    explicit ThreadFields(const Fields& fields) noexcept;
    ~ThreadFields();
    ThreadFields(const ThreadFields&) = delete;
    ThreadFields& operator=(const ThreadFields&) = delete;
    ThreadFields(ThreadFields&&) = delete;
    ThreadFields& operator=(ThreadFields&&) = delete;

private:
    Fields previous_;
};

// One line in a Ring: fixed size, truncated (the text, and the bus and drive names).
struct RingLine {
    Level level = Level::Info;
    std::uint16_t length = 0;
    std::uint8_t bus_length = 0;
    std::uint8_t drive_length = 0;
    std::source_location where;
    std::array<char, 256> text{};
    std::array<char, 32> bus{};
    std::array<char, 32> drive{};
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
    bool put(Level level, std::string_view message, const Fields& fields = {},
             std::source_location where = std::source_location::current()) noexcept;
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

inline void error(std::string_view m, const Fields& f = {}, std::source_location w = std::source_location::current()) {
    write(Level::Error, m, f, w);
}
inline void warning(std::string_view m, const Fields& f = {},
                    std::source_location w = std::source_location::current()) {
    write(Level::Warning, m, f, w);
}
inline void notice(std::string_view m, const Fields& f = {}, std::source_location w = std::source_location::current()) {
    write(Level::Notice, m, f, w);
}
inline void info(std::string_view m, const Fields& f = {}, std::source_location w = std::source_location::current()) {
    write(Level::Info, m, f, w);
}
inline void debug(std::string_view m, const Fields& f = {}, std::source_location w = std::source_location::current()) {
    write(Level::Debug, m, f, w);
}

// A fault that repeats (a slave timing out every poll) is logged the first time, then once
// per interval with the number of repeats in between.
class RateLimited {
public:
    explicit RateLimited(std::chrono::seconds interval = std::chrono::seconds(60)) : interval_(interval) {}
    void write(Level level, const std::string& key, std::string_view message, const Fields& fields = {},
               std::source_location where = std::source_location::current());
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
