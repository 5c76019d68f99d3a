#pragma once
/// @file
/// The zero of the angle, one rule for the board's position, a move's frame
/// and the host's log: theta = (d - d_zero) / r2 (docs/model.md section 4),
/// where d_zero is set (the `zero` command; a move's mean of readings at
/// rest) or else is the first good reading of a run. That one comes within
/// a sensor period of the start, before the sawtooth has moved the rotor: a
/// mean of the first few readings would hold the motion (8 readings at
/// 1 kHz put the frame 0.1 mrad off, measured). Allocation-free.

#include <limits>
#include <optional>

namespace piezo::firmware {

class AngleZero {
 public:
  AngleZero() = default;
  /// A zero already known (NaN: not yet).
  explicit AngleZero(double displacement_m) {
    if (displacement_m == displacement_m) zero_m_ = displacement_m;
  }

  void set(double displacement_m) { zero_m_ = displacement_m; }
  /// A good reading: the zero, when nobody set one yet.
  void offer(double displacement_m) {
    if (!zero_m_) zero_m_ = displacement_m;
  }

  [[nodiscard]] bool known() const { return zero_m_.has_value(); }
  [[nodiscard]] std::optional<double> value() const { return zero_m_; }
  /// The zero [m], NaN while unknown.
  [[nodiscard]] double displacement_m() const {
    return zero_m_.value_or(std::numeric_limits<double>::quiet_NaN());
  }
  /// The angle of a reading [rad]; NaN while the zero is unknown.
  [[nodiscard]] double angle_rad(double displacement_m, double r2_m) const {
    return (displacement_m - this->displacement_m()) / r2_m;
  }

 private:
  std::optional<double> zero_m_;
};

}  // namespace piezo::firmware
