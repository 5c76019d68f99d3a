#include "piezo/firmware/scan_controller.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace piezo::firmware {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// The reference's lag is corrected over this many periods (at least
/// kCorrectionFloor_s): faster would chase the noise of the filtered angle.
constexpr double kCorrectionPeriods = 3.0;
constexpr double kCorrectionFloor_s = 0.05;
/// The branch's prediction is scaled by what was measured, forgetting the
/// older periods at this rate.
constexpr double kGainMemory = 0.9;
/// ...within these bounds: an amplitude too small to step at all teaches
/// nothing about the larger ones.
constexpr double kGainMin = 0.5, kGainMax = 2.0;

double mean_std(double sum, double sum2, std::uint32_t n) {
  if (n < 2) return 0.0;
  const double mean = sum / n;
  return std::sqrt(std::max(0.0, (sum2 - n * mean * mean) / (n - 1)));
}

}  // namespace

ScanController::ScanController(const ScanSettings& settings, const PositionFeed& feed)
    : s_(settings),
      feed_(feed),
      approach_(settings.approach, feed),
      compare_(settings.compare),
      pulses_(std::make_unique<SpscRing<TriggerPulse>>(kPulseRing)),
      position_(kNaN) {
  dir_ = s_.to_rad >= s_.from_rad ? 1.0 : -1.0;
  rise_ = dir_ > 0.0 ? s_.D : 1.0 - s_.D;
  lag_s_ = 0.5 * (ReadingWindow::kSize - 1) / s_.sensor_rate_hz;
  v_base_ = std::min(s_.branch.base_rate(), s_.velocity_rad_per_s);
}

double ScanController::position_rad() const {
  if (stage() == ScanStage::approach) return approach_.position_rad();
  return position_.load(std::memory_order_relaxed);
}

StopCause ScanController::fault() const {
  return fault_seen_.load(std::memory_order_relaxed);
}

std::uint8_t ScanController::state_code() const {
  switch (stage()) {
    case ScanStage::approach:
      return approach_.state_code();
    case ScanStage::done:
      return static_cast<std::uint8_t>(MoveState::on_target);
    case ScanStage::failed:
      return static_cast<std::uint8_t>(
          fault() == StopCause::stalled ? MoveState::stalled : MoveState::sensor_implausible);
    default:
      return static_cast<std::uint8_t>(MoveState::coarse);
  }
}

bool ScanController::stepping() const {
  const ScanStage p = stage();
  if (p == ScanStage::approach) return approach_.stepping();
  return p == ScanStage::run_up || p == ScanStage::span || p == ScanStage::run_down;
}

void ScanController::fail(StopCause cause) {
  fault_ = cause;
  fault_seen_.store(cause, std::memory_order_relaxed);
  stage_.store(ScanStage::failed, std::memory_order_relaxed);
}

void ScanController::release_line() {
  if (s_.triggers && s_.lines != nullptr && line_high_) {
    (void)s_.lines->set_trigger(s_.axis, false);
    line_high_ = false;
  }
}

double ScanController::next_voltage(double t, double dt) {
  if (fault_ != StopCause::none) return 0.0;
  if (stage() == ScanStage::approach) {
    const double V = approach_.next_voltage(t, dt);
    if (approach_.fault() != StopCause::none) {
      fail(approach_.fault());
      return 0.0;
    }
    if (!approach_.finished()) return V;
    begin_cruise(t);  // on target at 0 V: the cruise starts from there
  }
  if (const std::uint64_t n = feed_.count(); n != seen_) {
    seen_ = n;
    on_reading(feed_.latest());
  }
  // The trigger line: a pulse's edge, or its end.
  if (s_.triggers) {
    bool level = false;
    TriggerPulse pulse;
    if (compare_.tick(t, level, pulse)) {
      fired_.fetch_add(1, std::memory_order_relaxed);
      if (pulse.late) late_.fetch_add(1, std::memory_order_relaxed);
      if (!pulses_->try_push(pulse)) unreported_.fetch_add(1, std::memory_order_relaxed);
    }
    if (level != line_high_ && s_.lines != nullptr) {
      (void)s_.lines->set_trigger(s_.axis, level);
      line_high_ = level;
    }
  }
  if (fault_ != StopCause::none || stage() == ScanStage::done) return 0.0;
  // The reference trajectory, tick by tick.
  theta_ref_ += dir_ * reference_velocity(t) * dt;
  if (t_decel_ < 0.0 && dir_ * (theta_ref_ - s_.to_rad) >= 0.0) t_decel_ = t;
  cycle_ += drive_.f_hz * dt;
  if (cycle_ >= 1.0) {
    cycle_ = 0.0;
    next_period(t);
    if (stage() == ScanStage::done || fault_ != StopCause::none) return 0.0;
  }
  const double A = drive_.fraction * s_.V0;
  return cycle_ < rise_ ? A * cycle_ / rise_ : A * (1.0 - cycle_) / (1.0 - rise_);
}

void ScanController::begin_cruise(double t) {
  t_cruise_ = t;
  theta_ref_ = have_theta_ ? theta_ : approach_.position_rad();
  if (!std::isfinite(theta_ref_)) theta_ref_ = s_.approach.target_rad;
  period_start_theta_ = theta_ref_;
  stage_.store(ScanStage::run_up, std::memory_order_relaxed);
  drive_ = {s_.branch.drive_for(v_base_).f_hz, 0.0};
  cycle_ = 1.0;  // the first period's drive is decided at once
}

double ScanController::reference_velocity(double t) const {
  const double v = s_.velocity_rad_per_s;
  if (t_decel_ >= 0.0) {
    if (s_.deceleration_s <= 0.0) return v_base_;
    return v - (v - v_base_) * std::min(1.0, (t - t_decel_) / s_.deceleration_s);
  }
  if (s_.acceleration_s <= 0.0) return v;
  return v_base_ + (v - v_base_) * std::min(1.0, (t - t_cruise_) / s_.acceleration_s);
}

void ScanController::on_reading(const PositionFeed::Reading& r) {
  const double theta = (r.displacement_m - s_.zero_displacement_m) / s_.r2_m;
  const double mean = window_.add(theta);
  if (!window_.full()) return;
  last_theta_ = have_theta_ ? theta_ : mean;
  theta_ = mean;
  have_theta_ = true;
  position_.store(theta_, std::memory_order_relaxed);
  if (s_.triggers) compare_.on_angle(theta_, r.t_ns);
  // The span's ends: when the filtered angle crossed A and B (between two
  // readings, linearly).
  const auto crossing_ns = [&](double at) {
    const double d = theta_ - last_theta_;
    const double u = d != 0.0 ? std::clamp((at - last_theta_) / d, 0.0, 1.0) : 1.0;
    return last_ns_ + static_cast<std::int64_t>(u * static_cast<double>(r.t_ns - last_ns_));
  };
  const ScanStage p = stage();
  if (p == ScanStage::run_up && dir_ * (theta_ - s_.from_rad) >= 0.0) {
    crossed_a_ns_ = last_ns_ != 0 ? crossing_ns(s_.from_rad) : r.t_ns;
    past_a_ = true;
    stage_.store(ScanStage::span, std::memory_order_relaxed);
  } else if (p == ScanStage::span && dir_ * (theta_ - s_.to_rad) >= 0.0) {
    crossed_b_ns_ = crossing_ns(s_.to_rad);
    past_b_ = true;
    stage_.store(ScanStage::run_down, std::memory_order_relaxed);
    finish_span();
  }
  last_ns_ = r.t_ns;
}

void ScanController::next_period(double t) {
  const ScanStage p = stage();
  if (p == ScanStage::span) record_period(t);
  // What the last period's drive gave, against what the branch predicted.
  if (drive_.fraction > 0.0 && have_theta_ && period_start_known_) {
    gain_measured_ = kGainMemory * gain_measured_ + dir_ * (theta_ - period_start_theta_);
    gain_predicted_ = kGainMemory * gain_predicted_ + s_.branch.velocity(drive_) / drive_.f_hz;
  }
  period_start_theta_ = theta_;
  period_start_known_ = have_theta_;
  // The run-down has run its course and the rotor is past B: the scan ends
  // here, on the period's 0 V.
  if (p == ScanStage::run_down && t_decel_ >= 0.0 && t - t_decel_ >= s_.deceleration_s &&
      (!s_.triggers || compare_.idle())) {
    stage_.store(ScanStage::done, std::memory_order_relaxed);
    drive_.fraction = 0.0;
    return;
  }
  const double v_ref = reference_velocity(t);
  // Behind the reference (positive) or ahead, as the filtered angle sees it.
  double lag = have_theta_ ? dir_ * (theta_ref_ - dir_ * v_ref * lag_s_ - theta_) : 0.0;
  if (p == ScanStage::run_up && lag < 0.0) {
    // Ahead while it runs up (a first step larger than the branch said):
    // the reference moves up to the rotor rather than hold it back, so
    // that the span starts on the reference, not catching up with it.
    theta_ref_ += -lag * dir_;
    lag = 0.0;
  }
  const double full_step = s_.branch.top() / std::max(drive_.f_hz, 1e-9);
  const double limit = std::max(s_.velocity_rad_per_s * s_.lag_limit_s, 5.0 * full_step);
  if (lag > limit) return fail(StopCause::stalled);
  if (-lag > limit) return fail(StopCause::sensor_implausible);
  const double period = 1.0 / std::max(drive_.f_hz, 1e-9);
  const double correction_s = std::max(kCorrectionPeriods * period, kCorrectionFloor_s);
  const double wanted = std::clamp(v_ref + lag / correction_s, 0.0, s_.branch.top());
  const double gain = gain_predicted_ > 0.0
                          ? std::clamp(gain_measured_ / gain_predicted_, kGainMin, kGainMax)
                          : 1.0;
  drive_ = s_.branch.drive_for(std::min(wanted / gain, s_.branch.top()));
  if (p == ScanStage::span) {
    f_sum_ += drive_.f_hz;
    fraction_sum_ += drive_.fraction;
  }
}

void ScanController::record_period(double t) {
  ++measured_.periods;
  if (period_t_ > 0.0 && t > period_t_) {
    const double v = dir_ * (theta_ - period_theta_) / (t - period_t_);
    v1_sum_ += v;
    v1_sum2_ += v * v;
    ++v1_n_;
  }
  period_t_ = t;
  period_theta_ = theta_;
  // Over ten periods: the angle ten period starts back.
  const std::size_t i = ten_n_ % ten_t_.size();
  ten_t_[i] = t;
  ten_theta_[i] = theta_;
  ++ten_n_;
  if (ten_n_ > 10) {
    const std::size_t back = (ten_n_ - 11) % ten_t_.size();
    const double v = dir_ * (theta_ - ten_theta_[back]) / (t - ten_t_[back]);
    v10_sum_ += v;
    v10_sum2_ += v * v;
    ++v10_n_;
  }
}

void ScanController::finish_span() {
  const double span_s = 1e-9 * static_cast<double>(crossed_b_ns_ - crossed_a_ns_);
  measured_.velocity_rad_per_s = span_s > 0.0 ? std::abs(s_.to_rad - s_.from_rad) / span_s : 0.0;
  measured_.ripple_rad_per_s = mean_std(v1_sum_, v1_sum2_, v1_n_);
  measured_.ripple_10_rad_per_s = mean_std(v10_sum_, v10_sum2_, v10_n_);
  if (measured_.periods > 0) {
    measured_.mean_f_hz = f_sum_ / measured_.periods;
    measured_.mean_fraction = fraction_sum_ / measured_.periods;
  }
  measured_ready_.store(true);
}

}  // namespace piezo::firmware
