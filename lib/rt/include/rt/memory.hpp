// SPDX-License-Identifier: Apache-2.0
// Locked memory for the real-time threads: what they run and touch (the daemon's code and
// data, its heap and stacks, the chunks it publishes in) stays resident, so that the bus
// thread never waits on a page fault; what it never touches is not locked just for being
// mapped. iceoryx's management segment is the large case: its broker's bookkeeping, sized for
// the most ports any RouDi may have, hundreds of MiB that mlockall() would make resident.
#pragma once

#include <cstddef>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus::rt {

// One line of /proc/PID/maps.
struct Mapping {
    std::uintptr_t begin = 0;
    std::uintptr_t end = 0;
    bool accessible = false;  // not PROT_NONE ("---p": guard pages, reserved address space)
    std::string path;         // the file, "[heap]", "[stack]", ...; empty: anonymous
    [[nodiscard]] std::size_t bytes() const noexcept { return end - begin; }
    // Backed by a file (code, data, shared memory): its pages come from the file, not zero.
    [[nodiscard]] bool file() const noexcept { return path.starts_with('/'); }
};

// /proc/PID/maps text, line by line; lines that do not parse are skipped.
[[nodiscard]] std::vector<Mapping> parse_maps(std::string_view maps);

// A "Name:   1234 kB" field of /proc/PID/status, in KiB; nullopt when it is missing.
[[nodiscard]] std::optional<std::size_t> status_kib(std::string_view status, std::string_view field);

// How each mapping is locked:
// - files (the program, its libraries, the payload segments) whole, every page read in: a code
//   path the bus thread takes for the first time must not wait for the disk;
// - anonymous memory (heap, thread stacks) as far as it is in use: the pages resident now, so
//   that an 8 MiB stack reservation costs what its thread actually used (the bus thread has
//   touched its stack ahead, see prefault_stack()) and VmLck says what is really held;
// - `left_out` files, address space only reserved (PROT_NONE: guard pages, malloc arenas not
//   grown into yet) and the kernel's own mappings ([vdso], [vvar], [vsyscall]) not at all.
enum class Lock : std::uint8_t { Whole, Resident, No };
[[nodiscard]] Lock how_to_lock(const Mapping& mapping, std::span<const std::string> left_out);

struct LockedMemory {
    std::size_t locked_kib = 0;    // VmLck afterwards
    std::size_t left_out_kib = 0;  // the size of the `left_out` mappings
};

// Locks the current mappings as how_to_lock() says. Call it once the shared memory is mapped
// and the threads run. Not mlockall(MCL_FUTURE): under it each malloc arena opened later
// reserves 64 MiB as locked (PROT_NONE, never resident, yet counted in VmLck; drivebusd showed
// 149 MiB of VmLck for 12 MiB of locked pages). So memory the daemon maps or grows into later
// is not locked: the bus thread's first touch of it is a minor fault, and with swap enabled it
// could be paged out. Needs CAP_IPC_LOCK, or an RLIMIT_MEMLOCK above what is locked.
[[nodiscard]] std::expected<LockedMemory, std::string> lock_memory(std::span<const std::string> left_out);

// Touches kStackPrefault bytes of the calling thread's stack below the current frame, so that
// those pages are resident (and locked, once lock_memory() has run) before the thread needs
// them. A bus thread's deepest call chain uses a small part of it.
inline constexpr std::size_t kStackPrefault = std::size_t{256} * 1024;
void prefault_stack() noexcept;

}  // namespace drivebus::rt
