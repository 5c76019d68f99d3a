#pragma once
/// @file
/// The rig's calibration as a drive program: a short designed experiment the
/// drive loop runs like any other program, measuring as it goes from the
/// acquire loop's readings.
///
/// 1. rest: the sensor's noise (the spread of kNoiseReadings readings at 0 V);
/// 2. DC holds over the fine range: the stator raised slowly (the rotor
///    sticks and follows) to a quarter, half, three quarters and all of it,
///    the angle at each: the angle per volt in stick; then released fast;
/// 3. for each frequency, at each of MoveSettings::kStepFractions of V0:
///    `steps` periods forward, rest, as many in reverse, rest: the step per
///    period each way (the mean angle at rest after, minus before, over the
///    count). Forward and reverse alternate, so the rotor ends near where it
///    began.
/// Rests are counted in readings (a settle of `flush_readings`, at least
/// 0.1 s: a rotor stepped at 40 Hz still creeps 2 mrad/s 30 ms after the
/// drive stopped; then the mean of kRestReadings), so a slow sensor gets
/// as many as a fast one.
/// Everything after construction happens inside next_voltage(): no
/// allocation, lock or throw.

#include <array>
#include <atomic>
#include <cstdint>

#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/move_controller.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/hal/backend.hpp"

namespace piezo::firmware {

struct CalibrationPlan {
  static constexpr int kMaxFrequencies = 4;
  static constexpr int kFractions = static_cast<int>(MoveSettings::kStepFractions.size());
  double V0 = 80.0;
  double D = 0.74955;  ///< forward rise fraction (reverse: 1 - D)
  double r2_m = hal::kDefaultSensorRadius_m;
  std::array<double, kMaxFrequencies> f_hz{10.0, 20.0, 40.0, 0.0};  ///< ascending
  int frequencies = 3;
  int steps = 4;             ///< periods per amplitude and direction
  int flush_readings = 100;  ///< readings skipped at the start of each rest
  double hold_V_max = 64.0;  ///< the fine range's top [V]
  double slow_slew_V_per_s = 400.0;
  double fast_slew_V_per_s = 8000.0;
  /// The plan's drive time [s] (rests depend on the sensor's rate: see
  /// duration_s).
  [[nodiscard]] double drive_s() const;
  /// An upper bound on the whole experiment at a sensor rate [s].
  [[nodiscard]] double duration_s(double sensor_rate_hz) const;
};

/// What the experiment measured (NaN where it could not).
struct CalibrationResult {
  double noise_m = 0.0;    ///< one reading's standard deviation at rest [m]
  double rad_per_V = 0.0;  ///< the angle per volt while the rotor sticks
  /// Step per period [rad, signed as measured: forward positive expected,
  /// reverse negative], per frequency and amplitude fraction.
  std::array<std::array<double, CalibrationPlan::kFractions>, CalibrationPlan::kMaxFrequencies>
      forward_rad{}, reverse_rad{};
  bool complete = false;  ///< every segment ran
};

class CalibrationProgram final : public DriveProgram {
 public:
  static constexpr int kNoiseReadings = 64;
  static constexpr int kRestReadings = 32;
  static constexpr int kHolds = 4;

  CalibrationProgram(const CalibrationPlan& plan, const PositionFeed& feed);

  double next_voltage(double t, double dt) override;
  [[nodiscard]] bool finished() const override { return done_.load(); }
  [[nodiscard]] std::uint8_t state_code() const override { return segment_kind_code(); }

  [[nodiscard]] const CalibrationPlan& plan() const { return plan_; }
  /// The measurements; complete once finished() (read after the run).
  [[nodiscard]] const CalibrationResult& result() const { return result_; }
  /// Progress through the experiment, 0..1 (any thread).
  [[nodiscard]] double progress() const {
    return static_cast<double>(done_segments_.load()) / static_cast<double>(count_);
  }

 private:
  enum class Kind : std::uint8_t { rest, ramp, steps };
  /// What a segment's measurement is for.
  enum class Role : std::uint8_t { none, noise, hold_base, hold, step_base, forward, reverse };
  struct Segment {
    Kind kind = Kind::rest;
    Role role = Role::none;
    double V_target = 0.0;  ///< ramp: where to; steps: the amplitude
    double slew = 0.0;      ///< ramp [V/s]
    double f = 0.0;         ///< steps: frequency
    double rise = 0.0;      ///< steps: rise fraction
    int count = 0;          ///< steps: periods; rest: readings to average
    int fi = 0, ai = 0, hold = 0;
  };
  static constexpr int kMaxSegments =
      4 + 4 * kHolds + 4 * CalibrationPlan::kMaxFrequencies * CalibrationPlan::kFractions;

  void add(const Segment& s);
  void begin(int index, double t);
  void on_reading(double t, double displacement_m);
  /// The rest segment's mean is in: record it for its role.
  void finish_rest(double mean_m);
  [[nodiscard]] std::uint8_t segment_kind_code() const;

  CalibrationPlan plan_;
  const PositionFeed& feed_;
  std::array<Segment, kMaxSegments> segments_{};
  int count_ = 0;
  int current_ = -1;
  double segment_start_ = 0.0;
  double V_ = 0.0;
  std::uint64_t seen_ = 0;
  // the current rest's readings
  int flush_ = 0, taken_ = 0;
  double sum_ = 0.0, sum2_ = 0.0;
  // measurements so far
  double base_m_ = 0.0;  ///< the last rest's mean before the segment being measured
  std::array<double, kHolds> hold_m_{}, hold_V_{};
  double hold_base_m_ = 0.0;
  CalibrationResult result_;
  std::atomic<int> done_segments_{0};
  std::atomic<bool> done_{false};
};

}  // namespace piezo::firmware
