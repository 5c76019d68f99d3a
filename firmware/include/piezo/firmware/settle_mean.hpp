#pragma once
/// @file
/// A settle's sliding mean of the last n readings at 0 V, widened (up to
/// kMax) when its verdict is not clear either way. Allocation-free.

#include <array>

namespace piezo::firmware {

class SettleMean {
 public:
  static constexpr int kMax = 256;  ///< readings a settle's mean may take

  /// A new settle over `n` readings (1..kMax).
  void start(int n);
  /// A reading; true once the mean holds n of them.
  bool add(double displacement_m);
  [[nodiscard]] double mean() const { return sum_ / n_; }
  [[nodiscard]] int readings() const { return n_; }
  /// Twice the readings (at most kMax), keeping those already held; false
  /// when it holds kMax already.
  bool widen();

 private:
  static constexpr int kRing = kMax + 1;  ///< one more: the one leaving the mean
  std::array<double, kRing> ring_{};
  int count_ = 0, next_ = 0, n_ = 8;
  double sum_ = 0.0;
};

}  // namespace piezo::firmware
