#include "piezo/firmware/run_guard.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::firmware {

RunGuard::RunGuard(const model::Excitation& waveform, const RunGuardSettings& settings,
                   const PositionFeed& feed)
    : waveform_(waveform), s_(settings), feed_(feed), seen_(feed.count()) {
  s_.periods = std::clamp(s_.periods, 1, RunGuardSettings::kMaxPeriods);
}

double RunGuard::progress_floor() const {
  const double averaged = s_.noise_m / std::sqrt(double{kFilter});
  return std::max(4.0 * averaged / s_.r2_m, 0.02 * s_.stroke_rad);
}

double RunGuard::next_voltage(double t, double dt) {
  const std::uint64_t count = feed_.count();
  if (count != seen_) {
    seen_ = count;
    on_reading(feed_.displacement_m());
  }
  // Judged at each period's end, once the readings have begun.
  if (judging_ && t * s_.f >= static_cast<double>(period_ + 1)) end_of_period();
  (void)dt;
  return waveform_.voltage(t);
}

void RunGuard::on_reading(double displacement_m) {
  const double theta = displacement_m / s_.r2_m;
  if (filled_ > 0 && displacement_m != last_raw_) ++changes_;
  last_raw_ = displacement_m;
  window_[static_cast<std::size_t>(next_slot_)] = displacement_m;
  next_slot_ = (next_slot_ + 1) % kFilter;
  filled_ = std::min(filled_ + 1, kFilter);
  double sum = 0.0;
  for (int i = 0; i < filled_; ++i) sum += window_[static_cast<std::size_t>(i)];
  theta_f_ = sum / filled_ / s_.r2_m;
  if (filled_ < kFilter) return;
  if (!judging_) {
    // The first full mean: where the judged periods begin.
    judging_ = true;
    low_ = high_ = theta_at_[0] = theta_f_;
    changes_at_[0] = changes_;
  }
  // A period's swing: its own raw readings' extremes (a mean of 8 would
  // smooth away the swing of periods shorter than 8 readings).
  if (in_period_++ == 0) low_ = high_ = theta;
  low_ = std::min(low_, theta);
  high_ = std::max(high_, theta);
}

void RunGuard::end_of_period() {
  const int K = s_.periods;
  const auto slot = [K](long i) { return static_cast<std::size_t>(i % (K + 1)); };
  ++period_;
  theta_at_[slot(period_)] = theta_f_;
  changes_at_[slot(period_)] = changes_;
  span_[slot(period_)] = {low_, high_};
  in_period_ = 0;
  if (fault_ != StopCause::none) return;
  const double floor = progress_floor();
  // One period is enough to see a sensor that does not see the rotor: in
  // every period of a sawtooth the rotor follows the stator's rise or is
  // dragged in its slip (a good part of the stroke), while noise alone
  // spans about 5 standard deviations; a frozen value does not change.
  const double swing_floor = std::max(8.0 * s_.noise_m / s_.r2_m, 0.05 * s_.stroke_rad);
  const auto& last = span_[slot(period_)];
  if (changes_ == changes_at_[slot(period_ - 1)] || last[1] - last[0] < swing_floor) {
    fault_ = StopCause::sensor_implausible;
    return;
  }
  if (period_ < K) return;
  const double progress = (theta_f_ - theta_at_[slot(period_ - K)]) * s_.direction;
  if (progress < -0.25 * K * s_.stroke_rad) {
    fault_ = StopCause::sensor_implausible;  // far against the drive
  } else if (progress < floor) {
    fault_ = StopCause::stalled;
  }
}

}  // namespace piezo::firmware
