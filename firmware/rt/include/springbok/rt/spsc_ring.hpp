// A lock-free single-producer / single-consumer ring of fixed-size records.
// The producer never blocks: a full ring drops the newest record and counts
// it. Used for the RT log (RT thread -> drainer) and the operator mailbox
// (server thread -> RT thread and back).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace springbok::rt {

template <class Record, std::size_t N>
class SpscRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "capacity must be a power of two");
  static_assert(std::is_trivially_copyable_v<Record>, "records are copied by value");
  static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

 public:
  // Producer side. rt: no alloc, no block
  bool push(const Record& record) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) == N) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    buffer_[head & (N - 1)] = record;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer side. rt: no alloc, no block
  bool pop(Record& out) noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    out = buffer_[tail & (N - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t pushed() const noexcept { return head_.load(std::memory_order_acquire); }
  static constexpr std::size_t capacity() noexcept { return N; }

 private:
  alignas(64) std::atomic<std::uint64_t> head_{0};  // written by the producer only
  alignas(64) std::atomic<std::uint64_t> tail_{0};  // written by the consumer only
  alignas(64) std::atomic<std::uint64_t> dropped_{0};
  Record buffer_[N];
};

}  // namespace springbok::rt
