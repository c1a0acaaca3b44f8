// Logging for drivebusd: one line per message on stderr, with the syslog priority prefix
// ("<4>") that journald reads when stderr is the journal, so levels survive without a
// library; repeats of the same fault are rate-limited (logged once, then counted).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace drivebus::log {

enum class Level : std::uint8_t { Error = 3, Warning = 4, Notice = 5, Info = 6, Debug = 7 };

// Journal prefixes when stderr is connected to the journal (JOURNAL_STREAM), plain
// "drivebusd: warning: ..." otherwise. Messages above `max` are dropped.
void init(std::string_view program, Level max);
void write(Level level, std::string_view message);

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
