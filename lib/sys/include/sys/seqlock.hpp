// SPDX-License-Identifier: Apache-2.0
// The latest value of a trivially copyable struct, written by one thread and read by any:
// the writer never waits (a reader that overlapped a write reads again), and no reader can
// delay the writer. Used for what the real-time bus thread shows other threads (its status).
// The value is kept in atomic words, so a torn read is retried, never undefined behaviour.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace drivebus::sys {

template <typename T>
class Seqlock {
    static_assert(std::is_trivially_copyable_v<T>);
    static constexpr std::size_t kWords = (sizeof(T) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);

public:
    Seqlock() { store(T{}); }

    // The one writer.
    void store(const T& value) noexcept {
        std::array<std::uint64_t, kWords> words{};
        std::memcpy(words.data(), &value, sizeof(T));
        const std::uint64_t s = sequence_.load(std::memory_order_relaxed);
        sequence_.store(s + 1, std::memory_order_relaxed);  // odd: a write is under way
        // Release on each word: a reader that sees any new word also sees the odd sequence
        // (no fence, which ThreadSanitizer cannot follow; on x86 these are plain stores).
        for (std::size_t i = 0; i < kWords; ++i) {
            words_[i].store(words[i], std::memory_order_release);
        }
        sequence_.store(s + 2, std::memory_order_release);
    }

    // Any reader: a consistent copy of the last value stored.
    [[nodiscard]] T load() const noexcept {
        std::array<std::uint64_t, kWords> words{};
        for (;;) {
            const std::uint64_t before = sequence_.load(std::memory_order_acquire);
            if ((before & 1U) != 0) {
                continue;
            }
            for (std::size_t i = 0; i < kWords; ++i) {
                words[i] = words_[i].load(std::memory_order_acquire);
            }
            if (sequence_.load(std::memory_order_relaxed) == before) {
                break;
            }
        }
        T value;
        std::memcpy(static_cast<void*>(&value), words.data(), sizeof(T));
        return value;
    }

private:
    std::atomic<std::uint64_t> sequence_{0};
    std::array<std::atomic<std::uint64_t>, kWords> words_{};
};

}  // namespace drivebus::sys
