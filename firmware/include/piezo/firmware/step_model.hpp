#pragma once
/// @file
/// A move's coarse-step model: the predicted step per period at each of
/// kStepFractions of V0 (the model's or a calibration's table), one way and
/// the other, scaled by what the measured steps teach. Allocation-free.

#include <array>

namespace piezo::firmware {

/// Amplitudes (fractions of V0) at which a step is predicted. Below about
/// half of V0 the motor hardly steps: that is the fine stage's range.
inline constexpr std::array<double, 6> kStepFractions{0.5, 0.6, 0.7, 0.8, 0.9, 1.0};

class StepModel {
 public:
  using Table = std::array<double, kStepFractions.size()>;  ///< step magnitudes [rad]
  static constexpr int kForward = 0, kReverse = 1;

  /// New tables; what was learnt is forgotten (a new frequency steps anew).
  void use(const Table& forward_rad, const Table& reverse_rad);
  [[nodiscard]] const Table& table(int k) const { return k == kForward ? forward_ : reverse_; }

  /// The predicted step [rad, magnitude] at `fraction` of V0 in direction k,
  /// interpolated in the table and scaled by what was learnt.
  [[nodiscard]] double predicted(int k, double fraction) const;
  /// The fraction of V0 (kStepFractions.front()..1) whose predicted step is
  /// `distance`: 1 when even a full step is short of it.
  [[nodiscard]] double fraction_for(int k, double distance) const;
  /// A step measured against its prediction: the scale moves most of the
  /// way (geometrically, within 1/4..4 a time) toward what was seen. A
  /// prediction below `noticeable` or a step that went nowhere teach nothing.
  void learn(int k, double measured_rad, double predicted_rad, double noticeable_rad);
  [[nodiscard]] double scale(int k) const { return scale_[k]; }

 private:
  Table forward_{}, reverse_{};
  std::array<double, 2> scale_{1.0, 1.0};
};

}  // namespace piezo::firmware
