#include "piezo/firmware/progress_judge.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::firmware {

double ReadingWindow::add(double displacement_m) {
  if (filled_ > 0 && displacement_m != last_) ++counts_.changes;
  ++counts_.readings;
  last_ = displacement_m;
  window_[static_cast<std::size_t>(next_)] = displacement_m;
  next_ = (next_ + 1) % kSize;
  filled_ = std::min(filled_ + 1, kSize);
  double sum = 0.0;
  for (int i = 0; i < filled_; ++i) sum += window_[static_cast<std::size_t>(i)];
  return sum / filled_;
}

namespace {

double noise_rad(const ProgressFloors& f) {
  return f.noise_m > 0.0 ? f.noise_m / f.r2_m : 0.0;  // NaN compares false: unknown
}

}  // namespace

double ProgressJudge::progress_floor(const ProgressFloors& f) {
  const double averaged = noise_rad(f) / std::sqrt(double{ReadingWindow::kSize});
  return std::max(4.0 * averaged, f.resolution_rad);
}

double ProgressJudge::swing_floor(const ProgressFloors& f) {
  return std::max(8.0 * noise_rad(f), 0.05 * f.stroke_rad);
}

void ProgressJudge::begin(int units, double theta_rad, ReadingCounts counts) {
  K_ = std::clamp(units, 1, kMaxUnits);
  completed_ = 0;
  theta_[0] = theta_rad;
  counts_[0] = counts;
  span_[0] = {theta_rad, theta_rad};
}

ProgressJudge::Verdict ProgressJudge::end_unit(double theta_rad, ReadingCounts counts,
                                               double low_rad, double high_rad, double direction,
                                               const ProgressFloors& floors) {
  if (completed_ < 0) return Verdict::progressing;
  ++completed_;
  theta_[slot(completed_)] = theta_rad;
  counts_[slot(completed_)] = counts;
  span_[slot(completed_)] = {low_rad, high_rad};
  last_unit_ = theta_rad - theta_[slot(completed_ - 1)];
  const auto seen_since = [&](int unit) {
    return counts.readings - counts_[slot(unit)].readings >= kReadingsToJudge;
  };
  const auto changed_since = [&](int unit) {
    return counts.changes != counts_[slot(unit)].changes;
  };
  // One unit is enough to see a sensor that does not see the rotor: in
  // every unit the rotor follows the stator's rise or is dragged in its
  // slip, while a frozen value does not change and noise alone hardly swings.
  if (seen_since(completed_ - 1) &&
      (!changed_since(completed_ - 1) || high_rad - low_rad < swing_floor(floors))) {
    return Verdict::implausible;
  }
  if (completed_ < K_) return Verdict::progressing;
  const int from = completed_ - K_;
  if (!seen_since(from)) return Verdict::progressing;  // no evidence either way
  progress_ = (theta_rad - theta_[slot(from)]) * direction;
  double low = theta_[slot(from)], high = low;
  for (int i = from + 1; i <= completed_; ++i) {
    low = std::min(low, span_[slot(i)][0]);
    high = std::max(high, span_[slot(i)][1]);
  }
  const double floor = progress_floor(floors);
  const double against = std::max(floor, 0.25 * K_ * floors.stroke_rad);
  if (!changed_since(from) || high - low < swing_floor(floors) || progress_ < -against) {
    return Verdict::implausible;
  }
  return progress_ < floor ? Verdict::stalled : Verdict::progressing;
}

}  // namespace piezo::firmware
