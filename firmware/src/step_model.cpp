#include "piezo/firmware/step_model.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::firmware {

void StepModel::use(const Table& forward_rad, const Table& reverse_rad) {
  forward_ = forward_rad;
  reverse_ = reverse_rad;
  scale_ = {1.0, 1.0};
}

double StepModel::predicted(int k, double fraction) const {
  const Table& t = table(k);
  const auto& at = kStepFractions;
  std::size_t i = 1;
  while (i + 1 < at.size() && fraction > at[i]) ++i;
  const double w = std::clamp((fraction - at[i - 1]) / (at[i] - at[i - 1]), 0.0, 1.0);
  return scale_[static_cast<std::size_t>(k)] * ((1.0 - w) * t[i - 1] + w * t[i]);
}

double StepModel::fraction_for(int k, double distance) const {
  if (distance >= predicted(k, 1.0)) return 1.0;
  double lo = kStepFractions.front(), hi = 1.0;
  while (hi - lo > 1e-3) {
    const double mid = 0.5 * (lo + hi);
    (predicted(k, mid) < distance ? lo : hi) = mid;
  }
  return lo;
}

void StepModel::learn(int k, double measured_rad, double predicted_rad, double noticeable_rad) {
  if (predicted_rad < noticeable_rad || measured_rad <= 0.0) return;
  scale_[static_cast<std::size_t>(k)] *=
      std::pow(std::clamp(measured_rad / predicted_rad, 0.25, 4.0), 0.7);
}

}  // namespace piezo::firmware
