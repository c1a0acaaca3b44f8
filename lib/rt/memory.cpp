// SPDX-License-Identifier: Apache-2.0
#include "rt/memory.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>

#include "sys/posix.hpp"

namespace drivebus::rt {
namespace {

constexpr std::string_view kBlanks = " \t";

// The next blank-separated field of `line`, consumed from it.
std::string_view next_field(std::string_view& line) {
    const auto start = line.find_first_not_of(kBlanks);
    if (start == std::string_view::npos) {
        line = {};
        return {};
    }
    line.remove_prefix(start);
    const auto end = std::min(line.find_first_of(kBlanks), line.size());
    const auto field = line.substr(0, end);
    line.remove_prefix(end);
    return field;
}

bool parse_hex(std::string_view text, std::uintptr_t& value) {
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value, 16);
    return error == std::errc{} && end == text.data() + text.size();
}

std::string slurp(const char* path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// Whether [begin, end) is still mapped: a thread may unmap memory while the locking runs.
bool still_mapped(const Mapping& mapping) {
    const auto now = parse_maps(slurp("/proc/self/maps"));
    return std::ranges::any_of(now, [&](const Mapping& m) { return m.begin <= mapping.begin && mapping.end <= m.end; });
}

}  // namespace

std::vector<Mapping> parse_maps(std::string_view maps) {
    std::vector<Mapping> out;
    while (!maps.empty()) {
        const auto eol = std::min(maps.find('\n'), maps.size());
        std::string_view line = maps.substr(0, eol);
        maps.remove_prefix(std::min(eol + 1, maps.size()));

        const auto range = next_field(line);
        const auto perms = next_field(line);
        for (int skipped = 0; skipped < 3; ++skipped) {  // offset, device, inode
            (void)next_field(line);
        }
        const auto dash = range.find('-');
        Mapping m;
        if (dash == std::string_view::npos || perms.size() < 3 || !parse_hex(range.substr(0, dash), m.begin) ||
            !parse_hex(range.substr(dash + 1), m.end) || m.end <= m.begin) {
            continue;
        }
        m.accessible = perms.substr(0, 3) != "---";
        // The path is the rest of the line; it may hold spaces.
        const auto path_start = line.find_first_not_of(' ');
        if (path_start != std::string_view::npos) {
            m.path = line.substr(path_start);
        }
        out.push_back(std::move(m));
    }
    return out;
}

std::optional<std::size_t> status_kib(std::string_view status, std::string_view field) {
    while (!status.empty()) {
        const auto eol = std::min(status.find('\n'), status.size());
        std::string_view line = status.substr(0, eol);
        status.remove_prefix(std::min(eol + 1, status.size()));
        if (!line.starts_with(field) || line.size() <= field.size() || line[field.size()] != ':') {
            continue;
        }
        line.remove_prefix(field.size() + 1);
        const auto number = next_field(line);
        std::size_t value = 0;
        const auto [end, error] = std::from_chars(number.data(), number.data() + number.size(), value);
        if (error != std::errc{} || end != number.data() + number.size()) {
            return std::nullopt;
        }
        return value;
    }
    return std::nullopt;
}

Lock how_to_lock(const Mapping& mapping, std::span<const std::string> left_out) {
    if (std::ranges::find(left_out, mapping.path) != left_out.end() || !mapping.accessible) {
        return Lock::No;
    }
    // [vdso], [vvar], [vsyscall] and the like belong to the kernel; [heap], [stack] and named
    // anonymous memory ([anon:...]) are the process's own.
    if (mapping.path.starts_with('[') && mapping.path != "[heap]" && mapping.path != "[stack]" &&
        !mapping.path.starts_with("[anon")) {
        return Lock::No;
    }
    return mapping.file() ? Lock::Whole : Lock::Resident;
}

namespace {

// mlock() of the runs of resident pages in `mapping` (mincore), so that nothing is added. A
// window at a time: a sanitizer's shadow memory is one mapping of terabytes.
std::expected<void, sys::SysError> lock_resident(const Mapping& mapping) {
    const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
    constexpr std::uintptr_t kWindowPages = std::uintptr_t{1} << 18;
    std::vector<unsigned char> resident(kWindowPages);
    for (std::uintptr_t window = mapping.begin; window < mapping.end; window += kWindowPages * page) {
        const std::uintptr_t pages = std::min(kWindowPages, (mapping.end - window) / page);
        auto* const start = reinterpret_cast<void*>(window);  // NOLINT(performance-no-int-to-ptr)
        if (auto probed = sys::posix_call("mincore", [&] { return ::mincore(start, pages * page, resident.data()); });
            !probed) {
            return std::unexpected(probed.error());
        }
        for (std::uintptr_t i = 0; i < pages;) {
            if ((resident[i] & 1U) == 0) {
                ++i;
                continue;
            }
            std::uintptr_t end = i;
            while (end < pages && (resident[end] & 1U) != 0) {
                ++end;
            }
            auto* const run = reinterpret_cast<void*>(window + i * page);  // NOLINT(performance-no-int-to-ptr)
            if (auto done = sys::posix_call("mlock", [&] { return ::mlock(run, (end - i) * page); }); !done) {
                return std::unexpected(done.error());
            }
            i = end;
        }
    }
    return {};
}

}  // namespace

std::expected<LockedMemory, std::string> lock_memory(std::span<const std::string> left_out) {
    const auto failed = [](const sys::SysError& error, const std::string& what) {
        // mincore() is refused only by a system call filter that leaves it out.
        const char* const needs = std::string_view(error.call) == "mincore" ? "a system call filter that allows mincore"
                                                                            : "CAP_IPC_LOCK or a memlock limit";
        return std::unexpected(std::string(error.call) + " " + what + ": " + std::strerror(error.error) + " (needs " +
                               needs + ")");
    };
    LockedMemory result;
    for (const Mapping& m : parse_maps(slurp("/proc/self/maps"))) {
        std::expected<void, sys::SysError> done;
        switch (how_to_lock(m, left_out)) {
        case Lock::No:
            if (std::ranges::find(left_out, m.path) != left_out.end()) {
                result.left_out_kib += m.bytes() / 1024;
            }
            continue;
        case Lock::Whole: {
            auto* const start = reinterpret_cast<void*>(m.begin);  // NOLINT(performance-no-int-to-ptr)
            if (auto locked = sys::posix_call("mlock", [&] { return ::mlock(start, m.bytes()); }); !locked) {
                done = std::unexpected(locked.error());
            }
            break;
        }
        case Lock::Resident: done = lock_resident(m); break;
        }
        // ENOMEM also says that the range is no longer (all) mapped: another thread unmapped it.
        if (!done && !(done.error().error == ENOMEM && !still_mapped(m))) {
            return failed(done.error(), m.path.empty() ? "anonymous memory" : m.path);
        }
    }
    result.locked_kib = status_kib(slurp("/proc/self/status"), "VmLck").value_or(0);
    return result;
}

void prefault_stack() noexcept {
    std::array<unsigned char, kStackPrefault> stack;  // NOLINT(cppcoreguidelines-pro-type-member-init)
    for (std::size_t i = 0; i < stack.size(); i += 1024) {
        stack[i] = 0;
    }
    // The stores must happen although nothing reads them.
    asm volatile("" : : "r"(stack.data()) : "memory");
}

}  // namespace drivebus::rt
