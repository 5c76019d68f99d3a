#include "piezo/firmware/velocity_branch.hpp"

#include <algorithm>

namespace piezo::firmware {

void VelocityBranch::add(double f_hz, const Table& steps_rad, bool reliable) {
  if (!reliable || closed_ || count_ == kMaxPoints) return;
  const Point p{f_hz, steps_rad};
  // The rising branch: a frequency that moves the rotor no faster than
  // the one below it ends the branch there; nothing after the peak joins.
  if (count_ > 0 && p.speed() <= points_[static_cast<std::size_t>(count_ - 1)].speed()) {
    closed_ = true;
    return;
  }
  points_[static_cast<std::size_t>(count_++)] = p;
}

double VelocityBranch::step_at(const Table& steps, double fraction) {
  if (fraction <= kStepFractions.front()) return steps.front();
  for (std::size_t i = 1; i < kStepFractions.size(); ++i) {
    if (fraction <= kStepFractions[i]) {
      const double u =
          (fraction - kStepFractions[i - 1]) / (kStepFractions[i] - kStepFractions[i - 1]);
      return steps[i - 1] + u * (steps[i] - steps[i - 1]);
    }
  }
  return steps.back();
}

double VelocityBranch::top() const {
  double best = 0.0;
  for (int i = 0; i < count_; ++i)
    best = std::max(best, points_[static_cast<std::size_t>(i)].speed());
  return best;
}

double VelocityBranch::base_rate() const {
  if (count_ == 0) return 0.0;
  const Point& low = points_.front();
  // The smallest amplitude whose step is a step (the table rises with it).
  for (std::size_t i = 0; i < kStepFractions.size(); ++i) {
    if (low.steps[i] > 0.0) return low.f_hz * low.steps[i];
  }
  return low.speed();
}

VelocityBranch::Drive VelocityBranch::drive_for(double v) const {
  const int n = count_;
  if (n == 0 || v <= 0.0) return {n > 0 ? points_.front().f_hz : 0.0, 0.0};
  const Point& low = points_.front();
  if (v < low.speed()) {
    // Below the lowest frequency's full step: that frequency, a smaller
    // amplitude (the table inverted; below its first entry, its first).
    for (std::size_t i = 1; i < kStepFractions.size(); ++i) {
      const double a = low.f_hz * low.steps[i - 1], b = low.f_hz * low.steps[i];
      if (v <= b && b > a) {
        const double u = std::clamp((v - a) / (b - a), 0.0, 1.0);
        return {low.f_hz, kStepFractions[i - 1] + u * (kStepFractions[i] - kStepFractions[i - 1])};
      }
    }
    return {low.f_hz, kStepFractions.front()};
  }
  for (int i = 1; i < n; ++i) {
    const Point& a = points_[static_cast<std::size_t>(i - 1)];
    const Point& b = points_[static_cast<std::size_t>(i)];
    if (v <= b.speed()) {
      // Velocity linear in frequency between two calibrated points.
      const double u = (v - a.speed()) / (b.speed() - a.speed());
      return {a.f_hz + u * (b.f_hz - a.f_hz), 1.0};
    }
  }
  return {points_[static_cast<std::size_t>(n - 1)].f_hz, 1.0};
}

double VelocityBranch::velocity(const Drive& d) const {
  const int n = count_;
  if (n == 0 || d.fraction <= 0.0) return 0.0;
  const Point& low = points_.front();
  if (d.f_hz <= low.f_hz) return d.f_hz * step_at(low.steps, d.fraction);
  for (int i = 1; i < n; ++i) {
    const Point& a = points_[static_cast<std::size_t>(i - 1)];
    const Point& b = points_[static_cast<std::size_t>(i)];
    if (d.f_hz <= b.f_hz) {
      const double u = (d.f_hz - a.f_hz) / (b.f_hz - a.f_hz);
      return (a.speed() + u * (b.speed() - a.speed())) * d.fraction;
    }
  }
  return points_[static_cast<std::size_t>(n - 1)].speed() * d.fraction;
}

}  // namespace piezo::firmware
