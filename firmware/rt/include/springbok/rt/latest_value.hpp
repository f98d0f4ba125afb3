// The newest value of a fixed-size record, from one writer thread to one reader
// thread, lock-free (a triple buffer): the writer never waits and never
// overwrites the slot the reader copies from; the reader gets the newest
// complete value, never a mix of two. Used for the controller's state that the
// operator server reports (RT thread -> server thread).
//
//   slots: [front: the reader's]  [middle: handed over]  [back: the writer's]
//   publish(): write back, swap back <-> middle, mark fresh
//   read():    if fresh, swap front <-> middle; copy front
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <type_traits>

namespace springbok::rt {

template <class Record>
class LatestValue {
  // Copied by value: fixed-size records only (Eigen's fixed-size matrices are
  // copyable without allocating, though not trivially copyable).
  static_assert(std::is_copy_assignable_v<Record> && std::is_default_constructible_v<Record>);
  static_assert(std::atomic<std::uint8_t>::is_always_lock_free);

 public:
  // Writer side. rt: no alloc, no block
  void publish(const Record& record) noexcept {
    slots_[back_] = record;
    back_ = static_cast<std::uint8_t>(middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh),
                                                       std::memory_order_acq_rel) &
                                      kIndex);
  }

  // Reader side: false until the first publish (out unchanged).
  bool read(Record& out) noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) != 0) {
      front_ = static_cast<std::uint8_t>(middle_.exchange(front_, std::memory_order_acq_rel) & kIndex);
      have_ = true;
    }
    if (have_) out = slots_[front_];
    return have_;
  }

 private:
  static constexpr std::uint8_t kIndex = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;

  std::array<Record, 3> slots_{};
  std::atomic<std::uint8_t> middle_{1};
  std::uint8_t back_ = 2;   // the writer's
  std::uint8_t front_ = 0;  // the reader's
  bool have_ = false;       // the reader's
};

}  // namespace springbok::rt
