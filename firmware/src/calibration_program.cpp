#include "piezo/firmware/calibration_program.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "piezo/firmware/voltage_limiter.hpp"

namespace piezo::firmware {
namespace {

constexpr double kUnmeasured = std::numeric_limits<double>::quiet_NaN();

}  // namespace

double CalibrationPlan::drive_s() const {
  double s = 0.0;
  for (int i = 0; i < frequencies; ++i)
    s += 2.0 * kFractions * steps / f_hz[static_cast<std::size_t>(i)];
  // The holds' slow ramps up, each release's fast one down.
  return s + hold_V_max / slow_slew_V_per_s + hold_V_max / fast_slew_V_per_s;
}

double CalibrationPlan::duration_s(double sensor_rate_hz) const {
  const int rests = 1 + CalibrationProgram::kHolds + 1 + 2 * kFractions * frequencies;
  const double readings = CalibrationProgram::kNoiseReadings +
                          rests * (flush_readings + CalibrationProgram::kRestReadings + 1);
  return drive_s() + readings / sensor_rate_hz;
}

CalibrationProgram::CalibrationProgram(const CalibrationPlan& plan, const PositionFeed& feed)
    : plan_(plan), feed_(feed), seen_(feed.count()) {
  result_.noise_m = result_.rad_per_V = kUnmeasured;
  for (auto& row : result_.forward_rad) row.fill(kUnmeasured);
  for (auto& row : result_.reverse_rad) row.fill(kUnmeasured);
  Segment s;
  s.kind = Kind::rest;
  s.role = Role::noise;
  s.count = kNoiseReadings;
  add(s);
  for (int h = 0; h < kHolds; ++h) {
    add({Kind::ramp, Role::none, plan.hold_V_max * (h + 1) / kHolds, plan.slow_slew_V_per_s});
    s = {};
    s.kind = Kind::rest;
    s.role = Role::hold;
    s.count = kRestReadings;
    s.hold = h;
    add(s);
  }
  add({Kind::ramp, Role::none, 0.0, plan.fast_slew_V_per_s});
  s = {};
  s.kind = Kind::rest;
  s.role = Role::step_base;
  s.count = kRestReadings;
  add(s);
  for (int fi = 0; fi < plan.frequencies; ++fi) {
    for (int ai = 0; ai < CalibrationPlan::kFractions; ++ai) {
      for (const bool forward : {true, false}) {
        Segment step;
        step.kind = Kind::steps;
        step.V_target = MoveSettings::kStepFractions[static_cast<std::size_t>(ai)] * plan.V0;
        step.f = plan.f_hz[static_cast<std::size_t>(fi)];
        step.rise = forward ? plan.D : 1.0 - plan.D;
        step.count = plan.steps;
        add(step);
        Segment rest;
        rest.kind = Kind::rest;
        rest.role = forward ? Role::forward : Role::reverse;
        rest.count = kRestReadings;
        rest.fi = fi;
        rest.ai = ai;
        add(rest);
      }
    }
  }
}

void CalibrationProgram::add(const Segment& s) {
  if (count_ < kMaxSegments) segments_[static_cast<std::size_t>(count_++)] = s;
}

void CalibrationProgram::begin(int index, double t) {
  done_segments_.store(std::max(0, index));
  current_ = index;
  segment_start_ = t;
  if (current_ >= count_) {
    result_.complete = true;
    done_.store(true);
    return;
  }
  flush_ = plan_.flush_readings;
  taken_ = 0;
  sum_ = sum2_ = 0.0;
}

double CalibrationProgram::next_voltage(double t, double dt) {
  if (current_ < 0) begin(0, t);
  if (done_.load(std::memory_order_relaxed)) return V_ = 0.0;
  const std::uint64_t count = feed_.count();
  const bool reading = count != seen_;
  seen_ = count;
  const Segment& s = segments_[static_cast<std::size_t>(current_)];
  switch (s.kind) {
    case Kind::rest:
      // A rest holds what the last segment left (0 V, or a hold's level).
      if (reading) on_reading(t, feed_.displacement_m());
      break;
    case Kind::ramp:
      V_ = step_towards(V_, s.V_target, s.slew, dt);
      if (V_ == s.V_target) begin(current_ + 1, t);
      break;
    case Kind::steps: {
      const double T = 1.0 / s.f;
      const double tau = t - segment_start_;
      if (tau >= s.count * T) {
        V_ = 0.0;
        begin(current_ + 1, t);
        break;
      }
      const double phase = std::fmod(tau, T), rise_time = s.rise * T;
      V_ = phase < rise_time ? s.V_target * phase / rise_time
                             : s.V_target * (T - phase) / (T - rise_time);
      break;
    }
  }
  return V_;
}

void CalibrationProgram::on_reading(double t, double displacement_m) {
  if (flush_ > 0) {
    --flush_;
    return;
  }
  sum_ += displacement_m;
  sum2_ += displacement_m * displacement_m;
  const Segment& s = segments_[static_cast<std::size_t>(current_)];
  if (++taken_ < s.count) return;
  const double n = taken_, mean = sum_ / n;
  if (s.role == Role::noise) {
    result_.noise_m = std::sqrt(std::max(0.0, sum2_ / n - mean * mean) * n / (n - 1.0));
  }
  finish_rest(mean);
  begin(current_ + 1, t);
}

void CalibrationProgram::finish_rest(double mean_m) {
  const Segment& s = segments_[static_cast<std::size_t>(current_)];
  const auto fi = static_cast<std::size_t>(s.fi), ai = static_cast<std::size_t>(s.ai);
  const double per_step = (mean_m - base_m_) / (plan_.r2_m * plan_.steps);
  switch (s.role) {
    case Role::noise:
      hold_base_m_ = mean_m;
      break;
    case Role::hold: {
      const auto h = static_cast<std::size_t>(s.hold);
      hold_m_[h] = mean_m;
      hold_V_[h] = plan_.hold_V_max * (s.hold + 1) / kHolds;
      if (s.hold + 1 == kHolds) {
        // The angle per volt: a least-squares line through the start.
        double sxy = 0.0, sxx = 0.0;
        for (std::size_t i = 0; i < kHolds; ++i) {
          sxy += hold_V_[i] * (hold_m_[i] - hold_base_m_) / plan_.r2_m;
          sxx += hold_V_[i] * hold_V_[i];
        }
        result_.rad_per_V = sxy / sxx;
      }
      break;
    }
    case Role::forward:
      result_.forward_rad[fi][ai] = per_step;
      break;
    case Role::reverse:
      result_.reverse_rad[fi][ai] = per_step;
      break;
    case Role::step_base:
    case Role::hold_base:
    case Role::none:
      break;
  }
  base_m_ = mean_m;
}

std::uint8_t CalibrationProgram::segment_kind_code() const {
  // In the drive record: 16 + the kind (rest 16, ramp 17, steps 18), apart
  // from a move's states (0..8).
  const int i = current_;
  if (i < 0 || i >= count_) return 0;
  return static_cast<std::uint8_t>(16 +
                                   static_cast<int>(segments_[static_cast<std::size_t>(i)].kind));
}

}  // namespace piezo::firmware
