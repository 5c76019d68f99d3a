#pragma once
/// @file
/// A move's active hold: once on target, the fine servo is kept on for
/// hold_s, and the averaged angle's distance from the target is recorded
/// (root mean square and largest magnitude), readable from any thread.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>

namespace piezo::firmware {

class ActiveHold {
 public:
  /// A hold from `t` [s] for `seconds`: the record starts afresh.
  void start(double t, double seconds) {
    until_ = t + seconds;
    sum2_ = largest_ = 0.0;
    n_ = 0;
  }
  [[nodiscard]] bool over(double t) const { return t >= until_; }
  /// One reading's error from the target [rad].
  void record(double error) {
    sum2_ += error * error;
    largest_ = std::max(largest_, std::abs(error));
    ++n_;
    rms_.store(std::sqrt(sum2_ / static_cast<double>(n_)));
    max_.store(largest_);
  }
  /// NaN before a hold has recorded anything.
  [[nodiscard]] double rms_error_rad() const { return rms_.load(); }
  [[nodiscard]] double max_error_rad() const { return max_.load(); }

 private:
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double until_ = 0.0, sum2_ = 0.0, largest_ = 0.0;
  std::uint64_t n_ = 0;
  std::atomic<double> rms_{kNaN};
  std::atomic<double> max_{kNaN};
};

}  // namespace piezo::firmware
