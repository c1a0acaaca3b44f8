// SPDX-License-Identifier: Apache-2.0
// A fixed-capacity, lock-free ring for one producer thread and one consumer thread: how the
// real-time bus thread and the threads below it hand data over without waiting on each other.
// Slots are allocated once, at construction; push and pop copy a trivially copyable entry and
// touch two atomics, so neither side ever blocks, allocates or makes a syscall. A full ring
// refuses the push (the caller decides what that means and counts it); nothing is overwritten.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>

namespace drivebus::sys {

template <typename T>
class SpscRing {
    static_assert(std::is_trivially_copyable_v<T>, "entries are copied between threads byte for byte");

public:
    explicit SpscRing(std::size_t capacity)
        : capacity_(capacity == 0 ? 1 : capacity), slots_(std::make_unique<T[]>(capacity_ + 1)) {}
    SpscRing(const SpscRing&) = delete;
    SpscRing& operator=(const SpscRing&) = delete;
    SpscRing(SpscRing&&) = delete;
    SpscRing& operator=(SpscRing&&) = delete;

    // Producer side. False when the ring is full: the entry was not taken.
    bool try_push(const T& entry) noexcept {
        const std::size_t tail = tail_.load(std::memory_order_relaxed);
        const std::size_t next = advance(tail);
        if (next == head_cache_) {
            head_cache_ = head_.load(std::memory_order_acquire);
            if (next == head_cache_) {
                return false;
            }
        }
        slots_[tail] = entry;
        tail_.store(next, std::memory_order_release);
        return true;
    }

    // Consumer side. False when the ring is empty.
    bool try_pop(T& out) noexcept {
        const std::size_t head = head_.load(std::memory_order_relaxed);
        if (head == tail_cache_) {
            tail_cache_ = tail_.load(std::memory_order_acquire);
            if (head == tail_cache_) {
                return false;
            }
        }
        out = slots_[head];
        head_.store(advance(head), std::memory_order_release);
        return true;
    }

    [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }
    // Entries in the ring; exact only on a side whose peer is idle.
    [[nodiscard]] std::size_t size() const noexcept {
        const std::size_t head = head_.load(std::memory_order_acquire);
        const std::size_t tail = tail_.load(std::memory_order_acquire);
        return tail >= head ? tail - head : tail + capacity_ + 1 - head;
    }

private:
    // One slot stays empty, so that head == tail means empty and tail + 1 == head means full.
    [[nodiscard]] std::size_t advance(std::size_t i) const noexcept { return i == capacity_ ? 0 : i + 1; }

    static constexpr std::size_t kLine = 64;  // apart, so the two sides do not share a cache line
    const std::size_t capacity_;
    const std::unique_ptr<T[]> slots_;
    alignas(kLine) std::atomic<std::size_t> head_{0};  // written by the consumer
    std::size_t tail_cache_ = 0;                       // the consumer's last look at tail_
    alignas(kLine) std::atomic<std::size_t> tail_{0};  // written by the producer
    std::size_t head_cache_ = 0;                       // the producer's last look at head_
};

}  // namespace drivebus::sys
