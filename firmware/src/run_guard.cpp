#include "piezo/firmware/run_guard.hpp"

#include <algorithm>

namespace piezo::firmware {

RunGuard::RunGuard(const model::Excitation& waveform, const RunGuardSettings& settings,
                   const PositionFeed& feed)
    : waveform_(waveform), s_(settings), feed_(feed), seen_(feed.count()) {
  s_.periods = std::clamp(s_.periods, 1, RunGuardSettings::kMaxPeriods);
}

ProgressFloors RunGuard::floors() const {
  return {s_.noise_m, s_.r2_m, s_.stroke_rad, 0.02 * s_.stroke_rad};
}

double RunGuard::next_voltage(double t, double dt) {
  const std::uint64_t count = feed_.count();
  if (count != seen_) {
    seen_ = count;
    on_reading(feed_.displacement_m());
  }
  // Judged at each period's end, once the readings have begun.
  if (judge_.running() && t * s_.f >= static_cast<double>(period_ + 1)) end_of_period();
  (void)dt;
  return waveform_.voltage(t);
}

void RunGuard::on_reading(double displacement_m) {
  const double theta = displacement_m / s_.r2_m;
  theta_f_ = window_.add(displacement_m) / s_.r2_m;
  if (!window_.full()) return;
  // The first full mean: where the judged periods begin.
  if (!judge_.running()) judge_.begin(s_.periods, theta_f_, window_.counts());
  // A period's swing: its own raw readings' extremes (a mean of 8 would
  // smooth away the swing of periods shorter than 8 readings).
  if (in_period_++ == 0) low_ = high_ = theta;
  low_ = std::min(low_, theta);
  high_ = std::max(high_, theta);
}

void RunGuard::end_of_period() {
  ++period_;
  const auto verdict =
      judge_.end_unit(theta_f_, window_.counts(), low_, high_, s_.direction, floors());
  in_period_ = 0;
  if (fault_ != StopCause::none) return;
  if (verdict == ProgressJudge::Verdict::implausible) fault_ = StopCause::sensor_implausible;
  if (verdict == ProgressJudge::Verdict::stalled) fault_ = StopCause::stalled;
}

}  // namespace piezo::firmware
