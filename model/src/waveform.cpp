#include "piezo/model/waveform.hpp"

#include <cmath>

namespace piezo::model {

Sawtooth::Sawtooth(double V0, double f, double D) : V0_(V0), T_(1.0 / f), D_(D) {}

double Sawtooth::voltage(double t) const {
  const double tau = t - std::floor(t / T_) * T_;
  const double rise = D_ * T_;
  if (tau < rise) return V0_ * tau / rise;
  return V0_ * (T_ - tau) / ((1.0 - D_) * T_);
}

double Sawtooth::next_breakpoint(double t) const {
  // Times within a tiny fraction of a period count as "at" a corner, so that a
  // caller standing on a corner (up to rounding) is sent to the next one.
  const double eps = 1e-9 * T_;
  const double k = std::floor((t + eps) / T_);
  const double peak_time = k * T_ + D_ * T_;
  if (peak_time > t + eps) return peak_time;
  return (k + 1.0) * T_;
}

LinearPiece Sawtooth::piece(double t) const {
  const double eps = 1e-9 * T_;
  const double start = std::floor((t + eps) / T_) * T_;
  const double rise = D_ * T_;
  if (t + eps < start + rise) return {start, 0.0, V0_ / rise};
  return {start + rise, V0_, -V0_ / ((1.0 - D_) * T_)};
}

}  // namespace piezo::model
