#pragma once
/// @file
/// One rule for whether a driven rotor progresses, for a move's coarse
/// steps (MoveController) and a plain run's periods (RunGuard) alike. The
/// caller ends a unit (a coarse step, a drive period) with the 8-reading
/// mean angle, the counts of readings so far and of those that changed, and
/// the unit's raw extremes:
/// - units that saw fewer than two readings show nothing of the sensor (a
///   frozen value takes two to be seen equal, a swing two ends): a sensor
///   late or silent is the staleness limit's (safety.sensor_stale_s), and a
///   loaded line that delivers none in a step is no frozen sensor;
/// - in the unit, no reading changed (a frozen sensor) or the raw readings
///   swung less than the swing floor while the stator swung (a sensor that
///   does not see the rotor); over the last K units, the same, or the angle
///   moved against the drive by more than a quarter of the stroke per
///   unit: `implausible`;
/// - the angle moved less than the progress floor the drive's way: `stalled`.
/// The floors, the one set of constants:
/// - swing floor: the larger of 8 standard deviations of a reading (noise
///   alone spans about 5 over a few hundred readings) and 5 % of the stroke
///   (a rotor in contact follows the stator's rise or is dragged in its slip);
/// - progress floor: the larger of 4 standard deviations of an 8-reading
///   mean and the caller's resolution (a move's half tolerance, a run's 2 %
///   of the stroke).
/// Allocation-free; called from the drive loop.

#include <array>
#include <cstdint>

#include "piezo/hal/backend.hpp"

namespace piezo::firmware {

/// Readings taken so far, and how many of them changed value.
struct ReadingCounts {
  std::uint64_t readings = 0;
  std::uint64_t changes = 0;
};

/// The readings' 8-sample mean and their counts.
class ReadingWindow {
 public:
  static constexpr int kSize = 8;
  /// A reading [m]; returns the mean of the last kSize (fewer at first).
  double add(double displacement_m);
  [[nodiscard]] bool full() const { return filled_ == kSize; }
  [[nodiscard]] int filled() const { return filled_; }
  [[nodiscard]] ReadingCounts counts() const { return counts_; }

 private:
  std::array<double, kSize> window_{};
  int filled_ = 0, next_ = 0;
  double last_ = 0.0;
  ReadingCounts counts_;
};

struct ProgressFloors {
  double noise_m = 0.0;  ///< a reading's standard deviation (0 or NaN: unknown)
  double r2_m = hal::kDefaultSensorRadius_m;
  double stroke_rad = 2.5e-3;   ///< the stator's swing as an angle, at the unit's amplitude
  double resolution_rad = 0.0;  ///< progress below this is none, whatever the noise allows
};

class ProgressJudge {
 public:
  static constexpr int kMaxUnits = 16;
  enum class Verdict : std::uint8_t { progressing, stalled, implausible };

  /// Readings a unit (or the last K) must have seen to be judged frozen,
  /// blind or moving against the drive.
  static constexpr std::uint64_t kReadingsToJudge = 2;

  /// A new run of units (K of them judged at a time, 1..kMaxUnits) from
  /// this angle and these counts.
  void begin(int units, double theta_rad, ReadingCounts counts);
  void end_run() { completed_ = -1; }
  [[nodiscard]] bool running() const { return completed_ >= 0; }
  [[nodiscard]] int completed() const { return completed_; }

  /// A unit's end, moving in `direction` (+1, -1). Judged once K units are
  /// complete; before that, `progressing`.
  Verdict end_unit(double theta_rad, ReadingCounts counts, double low_rad, double high_rad,
                   double direction, const ProgressFloors& floors);
  /// The angle gained the drive's way over the last K units (after a verdict).
  [[nodiscard]] double progress_rad() const { return progress_; }
  /// The angle of the unit just ended against the one before it.
  [[nodiscard]] double last_unit_rad() const { return last_unit_; }

  [[nodiscard]] static double progress_floor(const ProgressFloors& f);
  [[nodiscard]] static double swing_floor(const ProgressFloors& f);

 private:
  [[nodiscard]] std::size_t slot(int i) const { return static_cast<std::size_t>(i % (K_ + 1)); }
  int K_ = 2;
  int completed_ = -1;
  std::array<double, kMaxUnits + 1> theta_{};
  std::array<ReadingCounts, kMaxUnits + 1> counts_{};
  std::array<std::array<double, 2>, kMaxUnits + 1> span_{};
  double progress_ = 0.0, last_unit_ = 0.0;
};

}  // namespace piezo::firmware
