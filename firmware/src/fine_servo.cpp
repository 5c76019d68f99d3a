#include "piezo/firmware/fine_servo.hpp"

#include <algorithm>

#include "piezo/firmware/voltage_limiter.hpp"

namespace piezo::firmware {

void FineServo::raise_to(double V) {
  lifting_ = false;
  set_ = std::clamp(V, 0.0, s_.V_max);
}

void FineServo::lift_to(double V) {
  lifting_ = true;
  set_ = std::clamp(V, 0.0, s_.V_max);
}

double FineServo::output(double V, double dt, bool& lift_done) {
  const double out = step_towards(V, set_, lifting_ ? s_.fast_V_per_s : s_.slow_V_per_s, dt);
  lift_done = lifting_ && out == set_;
  if (lift_done) lifting_ = false;
  return out;
}

void FineServo::correct(double aim_error, double side) {
  const double next = std::clamp(set_ + kGain * aim_error / s_.rad_per_V, 0.0, s_.V_max);
  set_ = side > 0.0 ? std::max(set_, next) : side < 0.0 ? std::min(set_, next) : next;
}

bool FineServo::at_range_end(double aim_error, double tolerance_rad) const {
  return (set_ == 0.0 && aim_error < -tolerance_rad) ||
         (set_ == s_.V_max && aim_error > tolerance_rad);
}

}  // namespace piezo::firmware
