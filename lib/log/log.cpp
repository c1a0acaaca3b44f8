// SPDX-License-Identifier: Apache-2.0
#include "log/log.hpp"

// Without it, sd_journal_sendv() is a macro that adds CODE_FILE, CODE_LINE and CODE_FUNC of
// its own call here to those of the message's.
#define SD_JOURNAL_SUPPRESS_LOCATION
#include <systemd/sd-journal.h>

#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <thread>
#include <vector>

#include "log/stream_lines.hpp"
#include "sys/event_fd.hpp"
#include "sys/posix.hpp"

namespace drivebus::log {
namespace {

std::mutex g_mutex;
std::string g_program = "drivebusd";
std::atomic<Level> g_max{Level::Info};
bool g_journal = false;
thread_local Ring* t_ring = nullptr;
thread_local Fields t_fields;

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

class StandardBackend final : public Backend {
public:
    int send(std::span<const iovec> fields) noexcept override {
        // sd_journal_sendv() reports success when journald's socket is not there at all
        // (libsystemd "fails silently" then): the line would be lost.
        if (::access("/run/systemd/journal/socket", F_OK) != 0) {
            return -errno;
        }
        return sd_journal_sendv(fields.data(), static_cast<int>(fields.size()));
    }
    void print(std::string_view line) noexcept override { (void)std::fwrite(line.data(), 1, line.size(), stderr); }
};

StandardBackend g_standard;
std::atomic<Backend*> g_backend{&g_standard};

// With g_mutex held.
void print_line(Backend& backend, Level level, std::string_view message, bool journal_prefix) {
    std::string line;
    if (journal_prefix) {
        line = "<" + std::to_string(static_cast<int>(level)) + ">";
    } else {
        line = g_program + ": " + std::string(name_of(level)) + ": ";
    }
    line += message;
    line += '\n';
    backend.print(line);
}

void print(const Entry& raw) {
    std::string escaped;
    Entry entry = raw;
    if (std::ranges::any_of(raw.message, is_control)) {
        escaped = one_line(raw.message);
        entry.message = escaped;
    }
    const std::lock_guard lock(g_mutex);
    Backend& backend = *g_backend.load(std::memory_order_relaxed);
    if (g_journal) {
        const auto fields = journal_fields(g_program, entry);
        std::vector<iovec> vectors;
        vectors.reserve(fields.size());
        for (const auto& f : fields) {
            // NOLINTNEXTLINE(cppcoreguidelines-pro-type-const-cast): iovec's base is not const
            vectors.push_back(iovec{const_cast<char*>(f.data()), f.size()});
        }
        if (backend.send(vectors) >= 0) {
            return;
        }
        // journald refused it (gone, full): the line still goes out, on the stream.
    }
    print_line(backend, entry.level, entry.message, g_journal);
}

void set_field(std::string_view name, std::string_view value, std::vector<std::string>& out) {
    std::string field;
    field.reserve(name.size() + 1 + value.size());
    field += name;
    field += '=';
    field += value;
    out.push_back(std::move(field));
}

}  // namespace

bool is_journal_stream(const char* journal_stream, std::uint64_t device, std::uint64_t inode) noexcept {
    if (journal_stream == nullptr) {
        return false;
    }
    const std::string_view text(journal_stream);
    const auto colon = text.find(':');
    if (colon == std::string_view::npos) {
        return false;
    }
    const auto number = [](std::string_view digits) -> std::optional<std::uint64_t> {
        std::uint64_t value = 0;
        const auto* end = digits.data() + digits.size();
        const auto [at, ec] = std::from_chars(digits.data(), end, value);
        if (digits.empty() || ec != std::errc{} || at != end) {
            return std::nullopt;
        }
        return value;
    };
    const auto dev = number(text.substr(0, colon));
    const auto ino = number(text.substr(colon + 1));
    return dev && ino && *dev == device && *ino == inode;
}

std::vector<std::string> journal_fields(std::string_view program, const Entry& entry) {
    std::vector<std::string> out;
    out.reserve(8);
    set_field("MESSAGE", one_line(entry.message), out);
    set_field("PRIORITY", std::to_string(static_cast<int>(entry.level)), out);
    set_field("SYSLOG_IDENTIFIER", program, out);
    if (!entry.fields.bus.empty()) {
        set_field("BUS", entry.fields.bus, out);
    }
    if (!entry.fields.drive.empty()) {
        set_field("DRIVE", entry.fields.drive, out);
    }
    if (std::string_view file = entry.where.file_name(); !file.empty()) {
        // The build may name sources relative to its own directory ("../../daemon/main.cpp"):
        // what is left is their place in the source tree.
        while (file.starts_with("../") || file.starts_with("./")) {
            file.remove_prefix(file.find('/') + 1);
        }
        set_field("CODE_FILE", file, out);
        set_field("CODE_LINE", std::to_string(entry.where.line()), out);
    }
    if (const std::string_view function = entry.where.function_name(); !function.empty()) {
        set_field("CODE_FUNC", function, out);
    }
    return out;
}

void route_standard_streams() {
    static std::once_flag once;
    std::call_once(once, [] {
        const auto route = [](std::ostream& stream, Level others) {
            const auto on_line = [others](std::string_view line) {
                const std::source_location nowhere{};  // not a place in drivebus's code
                if (auto message = parse_iceoryx_message(line)) {
                    const auto level = static_cast<Level>(
                        std::clamp(message->priority, static_cast<int>(Level::Error), static_cast<int>(Level::Debug)));
                    write(level, "iceoryx: " + message->text, {}, nowhere);
                    return true;
                }
                std::string plain = without_escapes(line);
                plain.erase(plain.find_last_not_of(" \t\r") + 1);
                if (plain.empty()) {
                    return true;
                }
                if (is_iceoryx_line(line)) {
                    write(Level::Warning, "iceoryx: " + plain, {}, nowhere);
                } else {
                    write(others, plain, {}, nowhere);
                }
                return true;
            };
            // Never destroyed: iceoryx writes from static destructors at exit, and the standard
            // streams are flushed after every static object is gone.
            stream.rdbuf(new LineRouter(on_line));  // NOLINT(cppcoreguidelines-owning-memory)
        };
        route(std::cout, Level::Debug);
        route(std::clog, Level::Debug);
        route(std::cerr, Level::Warning);
    });
}

void set_backend(Backend* backend) noexcept {
    const std::lock_guard lock(g_mutex);
    g_backend.store(backend != nullptr ? backend : &g_standard, std::memory_order_relaxed);
}

bool to_journal() noexcept {
    const std::lock_guard lock(g_mutex);
    return g_journal;
}

ThreadFields::ThreadFields(const Fields& fields) noexcept : previous_(t_fields) {
    t_fields = fields;
}

ThreadFields::~ThreadFields() {
    t_fields = previous_;
}

namespace {

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
    struct stat err{};
    // NOLINTNEXTLINE(concurrency-mt-unsafe): read once, at start-up
    const char* stream = std::getenv("JOURNAL_STREAM");
    g_journal = ::fstat(STDERR_FILENO, &err) == 0 && is_journal_stream(stream, err.st_dev, err.st_ino);
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

void write(Level level, std::string_view message, const Fields& fields, std::source_location where) {
    if (!enabled(level)) {
        return;
    }
    const Fields merged{fields.bus.empty() ? t_fields.bus : fields.bus,
                        fields.drive.empty() ? t_fields.drive : fields.drive};
    if (t_ring != nullptr) {
        if (t_ring->put(level, message, merged, where)) {
            drainer().poke();
        }
        return;
    }
    print(Entry{level, message, merged, where});
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

bool Ring::put(Level level, std::string_view message, const Fields& fields, std::source_location where) noexcept {
    RingLine line;
    line.level = level;
    line.where = where;
    line.length = static_cast<std::uint16_t>(std::min(message.size(), line.text.size()));
    std::copy_n(message.begin(), line.length, line.text.begin());
    line.bus_length = static_cast<std::uint8_t>(std::min(fields.bus.size(), line.bus.size()));
    std::copy_n(fields.bus.begin(), line.bus_length, line.bus.begin());
    line.drive_length = static_cast<std::uint8_t>(std::min(fields.drive.size(), line.drive.size()));
    std::copy_n(fields.drive.begin(), line.drive_length, line.drive.begin());
    if (!lines_.try_push(line)) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return false;
    }
    return true;
}

void Ring::drain() {
    RingLine line;
    while (lines_.try_pop(line)) {
        print(Entry{line.level, std::string_view(line.text.data(), line.length),
                    Fields{std::string_view(line.bus.data(), line.bus_length),
                           std::string_view(line.drive.data(), line.drive_length)},
                    line.where});
    }
    if (const auto dropped = dropped_.load(std::memory_order_relaxed); dropped != dropped_reported_) {
        const std::string text = std::to_string(dropped - dropped_reported_) +
                                 " log lines of a real-time thread dropped: its log ring was full";
        print(Entry{Level::Warning, text, {}, std::source_location::current()});
        dropped_reported_ = dropped;
    }
}

void RateLimited::write(Level level, const std::string& key, std::string_view message, const Fields& fields,
                        std::source_location where) {
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
        log::write(level, std::string(message) + " (and " + std::to_string(suppressed) + " more times)", fields, where);
    } else {
        log::write(level, message, fields, where);
    }
}

void RateLimited::reset(const std::string& key) {
    const std::lock_guard lock(mutex_);
    entries_.erase(key);
}

}  // namespace drivebus::log
