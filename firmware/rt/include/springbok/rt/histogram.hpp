// A fixed-size histogram of non-negative durations: linear bins of a fixed
// width, an overflow count, and the exact minimum, maximum and mean. Filled by
// the RT thread (no allocation), read after the run or by a status snapshot.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>

namespace springbok::rt {

template <std::size_t NBins>
class Histogram {
 public:
  explicit Histogram(std::int64_t bin_width_ns = 1'000) noexcept : bin_width_ns_(bin_width_ns) {}

  // rt: no alloc
  void add(std::int64_t value_ns) noexcept {
    const std::int64_t v = std::max<std::int64_t>(value_ns, 0);
    const auto bin = static_cast<std::uint64_t>(v / bin_width_ns_);
    if (bin < NBins) {
      ++counts_[bin];
    } else {
      ++overflow_;
    }
    if (count_ == 0 || v < min_ns_) min_ns_ = v;
    if (v > max_ns_) max_ns_ = v;
    ++count_;
    sum_ns_ += static_cast<double>(v);
  }

  void reset() noexcept { *this = Histogram(bin_width_ns_); }

  std::uint64_t count() const noexcept { return count_; }
  std::uint64_t overflow() const noexcept { return overflow_; }
  std::int64_t min_ns() const noexcept { return min_ns_; }
  std::int64_t max_ns() const noexcept { return max_ns_; }
  std::int64_t bin_width_ns() const noexcept { return bin_width_ns_; }
  std::uint64_t bin_count(std::size_t bin) const noexcept { return counts_[bin]; }
  static constexpr std::size_t bins() noexcept { return NBins; }
  double mean_ns() const noexcept { return count_ == 0 ? 0.0 : sum_ns_ / static_cast<double>(count_); }

  // The smallest bin upper edge below which at least a fraction q (0..1) of
  // the samples lie, never above the exact maximum; 0 when empty.
  std::int64_t quantile_ns(double q) const noexcept {
    if (count_ == 0) return 0;
    const double wanted = q * static_cast<double>(count_);
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < NBins; ++b) {
      seen += counts_[b];
      if (static_cast<double>(seen) >= wanted && seen > 0) {
        return std::min<std::int64_t>(static_cast<std::int64_t>(b + 1) * bin_width_ns_, max_ns_);
      }
    }
    return max_ns_;  // the quantile lies in the overflow
  }

 private:
  std::int64_t bin_width_ns_;
  std::array<std::uint64_t, NBins> counts_{};
  std::uint64_t overflow_ = 0;
  std::uint64_t count_ = 0;
  std::int64_t min_ns_ = 0;
  std::int64_t max_ns_ = 0;
  double sum_ns_ = 0.0;
};

}  // namespace springbok::rt
