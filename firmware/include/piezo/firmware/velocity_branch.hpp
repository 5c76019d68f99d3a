#pragma once
/// @file
/// A stick-slip axis's steady velocity against its drive, as its
/// calibration measured it: at each calibrated frequency the step per
/// period at each of kStepFractions of V0, so a velocity f * step. Only the
/// rising branch counts (velocity growing with frequency, up to the fastest
/// reliable frequency): beyond it a faster drive moves the rotor slower.
/// Its top is the highest steady velocity; its base rate the slowest one
/// (the lowest frequency at the smallest amplitude that steps). A wanted
/// velocity maps to the drive that gives it: the frequency on the branch
/// at full amplitude, or below the lowest frequency's full step, that
/// frequency at a smaller amplitude. Fixed-size, no allocation.

#include <array>

#include "piezo/firmware/step_model.hpp"

namespace piezo::firmware {

class VelocityBranch {
 public:
  static constexpr int kMaxPoints = 4;
  using Table = StepModel::Table;  ///< step magnitudes [rad] at kStepFractions

  /// The drive for one period: its frequency and its amplitude as a
  /// fraction of V0 (0: no step this period).
  struct Drive {
    double f_hz = 0.0;
    double fraction = 0.0;
  };

  /// Adds a calibrated frequency's steps (magnitudes, in the scan's
  /// direction); `reliable` as the calibration judged them. Points must
  /// come in ascending frequency.
  void add(double f_hz, const Table& steps_rad, bool reliable);
  [[nodiscard]] bool empty() const { return count_ == 0; }
  /// The highest steady velocity [rad/s] (0: none).
  [[nodiscard]] double top() const;
  /// The slowest steady velocity [rad/s] (0: none).
  [[nodiscard]] double base_rate() const;
  /// The drive whose predicted velocity is v [rad/s, >= 0], within the branch.
  [[nodiscard]] Drive drive_for(double v) const;
  /// The velocity the branch predicts for a drive [rad/s].
  [[nodiscard]] double velocity(const Drive& d) const;

 private:
  struct Point {
    double f_hz = 0.0;
    Table steps{};
    [[nodiscard]] double speed() const { return f_hz * steps.back(); }
  };
  [[nodiscard]] static double step_at(const Table& steps, double fraction);
  std::array<Point, kMaxPoints> points_{};
  int count_ = 0;
  bool closed_ = false;  ///< past the peak
};

}  // namespace piezo::firmware
