#pragma once
/// @file
/// A plain run's protection (`[safety] protect_runs`): the sawtooth of a
/// timed run or a step, watched period by period the way a move's coarse
/// steps are (MoveController). Over the last `periods` drive periods:
/// readings that did not change at all, that did not swing while the
/// stator swung (a sensor that does not see the rotor), or that moved far
/// against the drive: `sensor_implausible`; no progress in the drive's
/// direction beyond the floor: `stalled`. Either ends the run at 0 V with
/// that cause. Everything happens inside next_voltage(): no allocation,
/// lock or throw.

#include <array>
#include <cstdint>

#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {

struct RunGuardSettings {
  static constexpr int kMaxPeriods = 16;
  int periods = 2;         ///< periods over which progress is judged (1..kMaxPeriods)
  double f = 10.0;         ///< the waveform's frequency [Hz]
  double direction = 1.0;  ///< +1 forward, -1 reverse
  double r2_m = 0.062;
  double stroke_rad = 2.5e-3;  ///< the stator's swing as an angle (angle per volt times V0)
  double noise_m = 0.0;        ///< a reading's noise (measured at rest, or a calibration's)
};

class RunGuard final : public DriveProgram {
 public:
  RunGuard(const model::Excitation& waveform, const RunGuardSettings& settings,
           const PositionFeed& feed);

  double next_voltage(double t, double dt) override;
  [[nodiscard]] double end_voltage(double duration_s) const override {
    return waveform_.voltage(duration_s);
  }
  [[nodiscard]] StopCause fault() const override { return fault_; }

  /// Progress below this over the judged periods is none [rad]: four
  /// standard deviations of an 8-reading mean, at least 2 % of the stroke.
  [[nodiscard]] double progress_floor() const;

 private:
  static constexpr int kFilter = 8;
  void on_reading(double displacement_m);
  void end_of_period();

  const model::Excitation& waveform_;
  RunGuardSettings s_;
  const PositionFeed& feed_;
  std::uint64_t seen_ = 0, changes_ = 0;
  std::array<double, kFilter> window_{};
  int filled_ = 0, next_slot_ = 0;
  double last_raw_ = 0.0, theta_f_ = 0.0, low_ = 0.0, high_ = 0.0;
  int in_period_ = 0;     ///< readings since the period began
  bool judging_ = false;  ///< the first full mean has come: periods are judged from it
  long period_ = 0;       ///< periods completed
  std::array<double, RunGuardSettings::kMaxPeriods + 1> theta_at_{};
  std::array<std::uint64_t, RunGuardSettings::kMaxPeriods + 1> changes_at_{};
  std::array<std::array<double, 2>, RunGuardSettings::kMaxPeriods + 1> span_{};
  StopCause fault_ = StopCause::none;
};

}  // namespace piezo::firmware
