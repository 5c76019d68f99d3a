#pragma once
/// @file
/// A plain run's protection (`[safety] protect_runs`): the sawtooth of a
/// timed run or a step, judged period by period by the rule a move's
/// coarse steps are judged by (ProgressJudge, over the last `periods`
/// periods): `sensor_implausible` or `stalled` ends the run at 0 V with
/// that cause. Everything happens inside next_voltage(): no allocation,
/// lock or throw.

#include <array>
#include <cstdint>

#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/firmware/progress_judge.hpp"
#include "piezo/hal/backend.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {

struct RunGuardSettings {
  static constexpr int kMaxPeriods = ProgressJudge::kMaxUnits;
  int periods = 2;         ///< periods over which progress is judged (1..kMaxPeriods)
  double f = 10.0;         ///< the waveform's frequency [Hz]
  double direction = 1.0;  ///< +1 forward, -1 reverse
  double r2_m = hal::kDefaultSensorRadius_m;
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

  /// The judge's floors for this run: a run's resolution is 2 % of the stroke.
  [[nodiscard]] ProgressFloors floors() const;

 private:
  void on_reading(double displacement_m);
  void end_of_period();

  const model::Excitation& waveform_;
  RunGuardSettings s_;
  const PositionFeed& feed_;
  std::uint64_t seen_ = 0;
  ReadingWindow window_;
  ProgressJudge judge_;
  double theta_f_ = 0.0, low_ = 0.0, high_ = 0.0;
  int in_period_ = 0;  ///< readings since the period began
  long period_ = 0;    ///< periods completed since judging began
  StopCause fault_ = StopCause::none;
};

}  // namespace piezo::firmware
