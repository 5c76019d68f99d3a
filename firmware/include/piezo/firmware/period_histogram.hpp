#pragma once
/// @file
/// Distribution of a loop's period error (wake-up lateness) with fixed
/// 1 us bins: recorded in the loop without allocation or lock. Writers: the
/// loop, or the acquire loops of a run (one per sensor line); any thread may
/// read it while they run (the live view): every counter is a relaxed atomic.

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>

#include "piezo/hal/clock.hpp"

namespace piezo::firmware {

class PeriodHistogram {
 public:
  static constexpr int kBins = 2000;  ///< 0..1999 us; later wake-ups land in the last bin

  void record(hal::TimeNs error_ns) {
    const hal::TimeNs clamped = std::max<hal::TimeNs>(error_ns, 0);
    const auto bin = std::min<hal::TimeNs>(clamped / 1000, kBins - 1);
    bump(bins_[static_cast<std::size_t>(bin)], std::uint64_t{1});
    bump(count_, std::uint64_t{1});
    hal::TimeNs max = max_ns_.load(std::memory_order_relaxed);
    while (clamped > max && !max_ns_.compare_exchange_weak(max, clamped, std::memory_order_relaxed)) {
    }
    bump(sum_ns_, clamped);
  }

  /// Upper edge [us] of the bin holding quantile q in [0, 1] (0 if empty).
  [[nodiscard]] double quantile_us(double q) const {
    const std::uint64_t count = this->count();
    if (count == 0) return 0.0;
    const auto rank = static_cast<std::uint64_t>(q * static_cast<double>(count - 1));
    std::uint64_t seen = 0;
    for (int i = 0; i < kBins; ++i) {
      seen += bins_[static_cast<std::size_t>(i)].load(std::memory_order_relaxed);
      if (seen > rank) return std::min(static_cast<double>(i + 1), max_us());
    }
    return max_us();
  }
  [[nodiscard]] double max_us() const {
    return static_cast<double>(max_ns_.load(std::memory_order_relaxed)) * 1e-3;
  }
  [[nodiscard]] double mean_us() const {
    const std::uint64_t count = this->count();
    return count == 0 ? 0.0
                      : static_cast<double>(sum_ns_.load(std::memory_order_relaxed)) * 1e-3 /
                            static_cast<double>(count);
  }
  [[nodiscard]] std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }
  /// A copy of the bins, counts per 1 us of period error.
  [[nodiscard]] std::array<std::uint64_t, kBins> bins() const {
    std::array<std::uint64_t, kBins> out;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = bins_[i].load(std::memory_order_relaxed);
    return out;
  }

 private:
  template <class T>
  static void bump(std::atomic<T>& counter, T by) {
    counter.fetch_add(by, std::memory_order_relaxed);
  }

  std::array<std::atomic<std::uint64_t>, kBins> bins_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<hal::TimeNs> max_ns_{0};
  std::atomic<hal::TimeNs> sum_ns_{0};
};

}  // namespace piezo::firmware
