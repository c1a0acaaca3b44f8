#include "log/log.hpp"

#include <cstdio>
#include <cstdlib>

namespace drivebus::log {
namespace {

std::mutex g_mutex;
std::string g_program = "drivebusd";
Level g_max = Level::Info;
bool g_journal = false;

std::string_view name_of(Level level) {
    switch (level) {
    case Level::Error: return "error";
    case Level::Warning: return "warning";
    case Level::Notice: return "notice";
    case Level::Info: return "info";
    case Level::Debug: return "debug";
    }
    return "info";
}

}  // namespace

void init(std::string_view program, Level max) {
    const std::lock_guard lock(g_mutex);
    g_program = program;
    g_max = max;
    g_journal = std::getenv("JOURNAL_STREAM") != nullptr;
}

void write(Level level, std::string_view message) {
    if (level > g_max) {
        return;
    }
    const std::lock_guard lock(g_mutex);
    if (g_journal) {
        std::fprintf(stderr, "<%d>%.*s\n", static_cast<int>(level), static_cast<int>(message.size()), message.data());
    } else {
        const auto name = name_of(level);
        std::fprintf(stderr, "%s: %.*s: %.*s\n", g_program.c_str(), static_cast<int>(name.size()), name.data(),
                     static_cast<int>(message.size()), message.data());
    }
}

void RateLimited::write(Level level, const std::string& key, std::string_view message) {
    const auto now = std::chrono::steady_clock::now();
    std::uint64_t suppressed = 0;
    {
        const std::lock_guard lock(mutex_);
        auto [it, fresh] = entries_.try_emplace(key);
        if (!fresh && now - it->second.last < interval_) {
            ++it->second.suppressed;
            return;
        }
        suppressed = it->second.suppressed;
        it->second = Entry{now, 0};
    }
    if (suppressed > 0) {
        log::write(level, std::string(message) + " (and " + std::to_string(suppressed) + " more times)");
    } else {
        log::write(level, message);
    }
}

void RateLimited::reset(const std::string& key) {
    const std::lock_guard lock(mutex_);
    entries_.erase(key);
}

}  // namespace drivebus::log
