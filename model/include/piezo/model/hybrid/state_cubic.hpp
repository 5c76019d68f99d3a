#pragma once
/// @file
/// The cubic Hermite interpolant of the motor's state between two steps of
/// the hybrid's linear and stick modes, where most samples of a run fall.

#include <array>
#include <cstddef>

#include "piezo/model/motor.hpp"

namespace piezo::model::hybrid {

/// Each state as a polynomial in u = (t - t0)/h, from its values and slopes
/// at both ends: worked out once a step, a sample costs three multiply-adds
/// per state (the samples outnumber the steps they fall in some twenty to
/// one at 10 kHz).
class StateCubic {
 public:
  StateCubic(double t0, const LuGreState& y0, const LuGreState& f0, double t1, const LuGreState& y1,
             const LuGreState& f1)
      : t0_(t0), inverse_h_(1.0 / (t1 - t0)) {
    const double h = t1 - t0;
    for (std::size_t i = 0; i < 5; ++i) {
      const double rise = y1[i] - y0[i], m0 = h * f0[i], m1 = h * f1[i];
      c_[i] = {y0[i], m0, 3.0 * rise - 2.0 * m0 - m1, m0 + m1 - 2.0 * rise};
    }
  }

  [[nodiscard]] double u(double t) const { return (t - t0_) * inverse_h_; }
  /// State i at u.
  [[nodiscard]] double at(std::size_t i, double u) const {
    return c_[i][0] + u * (c_[i][1] + u * (c_[i][2] + u * c_[i][3]));
  }
  [[nodiscard]] LuGreState at(double t) const {
    const double v = u(t);
    LuGreState out{};
    for (std::size_t i = 0; i < 5; ++i) out[i] = at(i, v);
    return out;
  }

 private:
  double t0_, inverse_h_;
  std::array<std::array<double, 4>, 5> c_{};  // [state][power of u]
};

}  // namespace piezo::model::hybrid
