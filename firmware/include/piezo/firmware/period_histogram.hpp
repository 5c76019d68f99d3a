#pragma once
/// @file
/// Distribution of a loop's period error (wake-up lateness) with fixed
/// 1 us bins: recorded in the loop without allocation, summarised after.

#include <algorithm>
#include <array>
#include <cstdint>

#include "piezo/hal/clock.hpp"

namespace piezo::firmware {

class PeriodHistogram {
 public:
  static constexpr int kBins = 2000;  ///< 0..1999 us; later wake-ups land in the last bin

  void record(hal::TimeNs error_ns) {
    const hal::TimeNs clamped = std::max<hal::TimeNs>(error_ns, 0);
    const auto bin = std::min<hal::TimeNs>(clamped / 1000, kBins - 1);
    ++bins_[static_cast<std::size_t>(bin)];
    ++count_;
    max_ns_ = std::max(max_ns_, clamped);
    sum_ns_ += clamped;
  }

  /// Upper edge [us] of the bin holding quantile q in [0, 1] (0 if empty).
  [[nodiscard]] double quantile_us(double q) const {
    if (count_ == 0) return 0.0;
    const auto rank = static_cast<std::uint64_t>(q * static_cast<double>(count_ - 1));
    std::uint64_t seen = 0;
    for (int i = 0; i < kBins; ++i) {
      seen += bins_[static_cast<std::size_t>(i)];
      if (seen > rank) return std::min(static_cast<double>(i + 1), max_us());
    }
    return max_us();
  }
  [[nodiscard]] double max_us() const { return static_cast<double>(max_ns_) * 1e-3; }
  [[nodiscard]] double mean_us() const {
    return count_ == 0 ? 0.0 : static_cast<double>(sum_ns_) * 1e-3 / static_cast<double>(count_);
  }
  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] const std::array<std::uint64_t, kBins>& bins() const { return bins_; }

 private:
  std::array<std::uint64_t, kBins> bins_{};
  std::uint64_t count_ = 0;
  hal::TimeNs max_ns_ = 0;
  hal::TimeNs sum_ns_ = 0;
};

}  // namespace piezo::firmware
