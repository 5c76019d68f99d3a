#pragma once
/// @file
/// x^(1/N) for the series' step bound, at a third of std::pow's latency:
/// the bound's root is on every series step's critical path, and pow was
/// an eighth of a LuGre run at 10 and 20 Hz (bench_simulate, perf).

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace piezo::model::hybrid {

/// x^(1/N), relative error below 1e-9 (nth_root_test checks it against
/// std::pow). With x = 2^e m, m in [1, 2): 2^(e/N) is 2^q 2^(r/N), the
/// latter from a table; m^(1/N) is c^(1/N) (1 + d)^(1/N) for the nearest
/// of 32 centres c, from tables, with |d| <= 1/64 and the binomial series
/// to d^3. The tables are worked out once, by std::pow, at start-up.
template <int N>
class NthRoot {
 public:
  NthRoot() {
    for (int r = 0; r < N; ++r) exponent_part_[r] = std::pow(2.0, static_cast<double>(r) / N);
    for (int i = 0; i < kCentres; ++i) {
      const double centre = 1.0 + (i + 0.5) / kCentres;
      inverse_centre_[i] = 1.0 / centre;
      centre_part_[i] = std::pow(centre, 1.0 / N);
    }
  }

  [[nodiscard]] double operator()(double x) const {
    if (!(x >= std::numeric_limits<double>::min() && x <= std::numeric_limits<double>::max())) {
      return std::pow(x, 1.0 / N);  // zero, subnormal, infinite or NaN
    }
    const auto bits = std::bit_cast<std::uint64_t>(x);
    const int e = static_cast<int>(bits >> 52) - 1023;
    const double m = std::bit_cast<double>((bits & kMantissa) | kOne);
    const int i = static_cast<int>((bits & kMantissa) >> (52 - kCentreBits));
    // e = q N + r with 0 <= r < N (floor division for negative e).
    const int q = (e >= 0 ? e : e - (N - 1)) / N;
    const int r = e - q * N;
    const double d = m * inverse_centre_[i] - 1.0;
    constexpr double p = 1.0 / N, c2 = p * (p - 1.0) / 2.0, c3 = c2 * (p - 2.0) / 3.0;
    const double series = (1.0 + p * d) + (d * d) * (c2 + c3 * d);
    const double two_q = std::bit_cast<double>(static_cast<std::uint64_t>(q + 1023) << 52);
    return (two_q * exponent_part_[r]) * (centre_part_[i] * series);
  }

 private:
  static constexpr int kCentreBits = 5, kCentres = 1 << kCentreBits;
  static constexpr std::uint64_t kMantissa = (std::uint64_t{1} << 52) - 1;
  static constexpr std::uint64_t kOne = std::uint64_t{1023} << 52;
  std::array<double, N> exponent_part_{};
  std::array<double, kCentres> inverse_centre_{}, centre_part_{};
};

}  // namespace piezo::model::hybrid
