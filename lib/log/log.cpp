// SPDX-License-Identifier: Apache-2.0
#include "log/log.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "sys/event_fd.hpp"
#include "sys/posix.hpp"

namespace drivebus::log {
namespace {

std::mutex g_mutex;
std::string g_program = "drivebusd";
std::atomic<Level> g_max{Level::Info};
bool g_journal = false;
thread_local Ring* t_ring = nullptr;

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

bool is_control(char c) noexcept {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 || u == 0x7F;
}

void print(Level level, std::string_view raw) {
    std::string escaped;
    std::string_view message = raw;
    if (std::ranges::any_of(raw, is_control)) {
        escaped = one_line(raw);
        message = escaped;
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

// The thread that writes what the rings hold. Started with the first ring; the rings'
// threads only write its eventfd, they never take its mutex.
class Drainer {
public:
    Drainer() : wake_("eventfd for the log") {
        thread_ = std::thread([this] { run(); });
    }
    ~Drainer() {
        stopping_ = true;
        poke();
        thread_.join();
    }
    Drainer(const Drainer&) = delete;
    Drainer& operator=(const Drainer&) = delete;
    Drainer(Drainer&&) = delete;
    Drainer& operator=(Drainer&&) = delete;

    void add(Ring* ring) {
        const std::lock_guard lock(mutex_);
        rings_.push_back(ring);
    }
    void remove(Ring* ring) {
        const std::lock_guard lock(mutex_);
        ring->drain();
        std::erase(rings_, ring);
    }
    void poke() const noexcept { wake_.signal(); }

private:
    void run() {
        while (!stopping_) {
            pollfd p{wake_.fd(), POLLIN, 0};
            (void)::poll(&p, 1, 1000);
            wake_.drain();
            const std::lock_guard lock(mutex_);
            for (auto* ring : rings_) {
                ring->drain();
            }
        }
    }

    sys::EventFd wake_;
    std::mutex mutex_;  // the drain thread and the threads that create and destroy rings
    std::vector<Ring*> rings_;
    std::atomic<bool> stopping_{false};
    std::thread thread_;
};

Drainer& drainer() {
    static Drainer d;
    return d;
}

}  // namespace

void init(std::string_view program, Level max) {
    const std::lock_guard lock(g_mutex);
    g_program = program;
    g_max = max;
    g_journal = std::getenv("JOURNAL_STREAM") != nullptr;
}

bool enabled(Level level) noexcept {
    return level <= g_max.load(std::memory_order_relaxed);
}

std::string one_line(std::string_view message) {
    std::string out;
    out.reserve(message.size());
    for (const char c : message) {
        if (is_control(c)) {
            static constexpr std::string_view kHex = "0123456789ABCDEF";
            const auto u = static_cast<unsigned char>(c);
            out += "\\x";
            out += kHex[u >> 4U];
            out += kHex[u & 0xFU];
        } else {
            out += c;
        }
    }
    return out;
}

void write(Level level, std::string_view message) {
    if (!enabled(level)) {
        return;
    }
    if (t_ring != nullptr) {
        if (t_ring->put(level, message)) {
            drainer().poke();
        }
        return;
    }
    print(level, message);
}

Ring::Ring(std::size_t capacity, bool drained) : lines_(capacity), drained_(drained) {
    if (drained_) {
        drainer().add(this);
    }
}

Ring::~Ring() {
    if (drained_) {
        drainer().remove(this);
    }
}

void Ring::use_on_this_thread() noexcept {
    t_ring = this;
}

bool Ring::put(Level level, std::string_view message) noexcept {
    RingLine line;
    line.level = level;
    line.length = static_cast<std::uint16_t>(std::min(message.size(), line.text.size()));
    std::copy_n(message.begin(), line.length, line.text.begin());
    if (!lines_.try_push(line)) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return false;
    }
    return true;
}

void Ring::drain() {
    RingLine line;
    while (lines_.try_pop(line)) {
        print(line.level, std::string_view(line.text.data(), line.length));
    }
    if (const auto dropped = dropped_.load(std::memory_order_relaxed); dropped != dropped_reported_) {
        print(Level::Warning, std::to_string(dropped - dropped_reported_) +
                                  " log lines of a real-time thread dropped: its log ring was full");
        dropped_reported_ = dropped;
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
