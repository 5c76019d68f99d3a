#pragma once
/// @file
/// A constant-velocity move (a fly scan's) from A to B at a mean velocity
/// v, closed loop on the measured angle, run by the drive loop as a
/// DriveProgram:
/// - approach: a closed-loop move (MoveController) to the run-up's start,
///   before A, arriving from the side the scan leaves from;
/// - cruise: a sawtooth whose frequency and amplitude are chosen anew at
///   every period's start from the axis's calibrated velocity branch
///   (VelocityBranch), for the reference velocity plus the measured lag
///   behind the reference trajectory (its angle integrates the reference
///   velocity: the mean velocity over the span is v whatever the
///   branch's error); the branch's prediction is scaled by the velocity
///   measured so far. The reference runs up from the base rate to v over
///   acceleration_s before A, and down again over deceleration_s after B;
///   the scan ends on a period's 0 V;
/// - triggers: position compare (PositionCompare) on the same filtered
///   angle the loop follows, its pulses written to the axis's trigger line
///   and kept, each with its k, its angle and its times, for the network
///   thread;
/// - protection: a rotor that falls behind its reference by more than
///   lag_limit_s of travel (or five full steps) has stalled; one ahead by
///   as much is no rotor this drive moves (sensor_implausible). The
///   approach's own protection holds before.
/// What the span measured (its mean velocity between the readings that
/// crossed A and B, the ripple of the velocity per period and over ten
/// periods) is readable from any thread once the scan has passed B.
/// Everything happens inside next_voltage(): no allocation, lock or throw.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>

#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/move_controller.hpp"
#include "piezo/firmware/position_compare.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/firmware/progress_judge.hpp"
#include "piezo/firmware/spsc_ring.hpp"
#include "piezo/firmware/velocity_branch.hpp"
#include "piezo/hal/backend.hpp"
#include "piezo/hal/digital_lines.hpp"

namespace piezo::firmware {

enum class ScanStage : std::uint8_t { approach, run_up, span, run_down, done, failed };

struct ScanSettings {
  double from_rad = 0.0, to_rad = 0.0;  ///< A and B, from the axis's zero
  double velocity_rad_per_s = 0.0;      ///< v (> 0) over A..B
  double acceleration_s = 0.0;          ///< from the base rate to v, before A
  double deceleration_s = 0.0;          ///< from v to the base rate, after B
  double zero_displacement_m = 0.0;     ///< the axis's zero (known: the approach's too)
  double r2_m = hal::kDefaultSensorRadius_m;
  double V0 = 80.0;    ///< the sawtooth's full amplitude [V]
  double D = 0.74955;  ///< forward rise fraction (reverse: 1 - D)
  double sensor_rate_hz = 1000.0;
  double lag_limit_s = 1.0;
  VelocityBranch branch;  ///< in the scan's direction
  MoveSettings approach;  ///< its target: the run-up's start
  bool triggers = false;
  CompareSettings compare;
  hal::DigitalLines* lines = nullptr;  ///< the trigger line's, with triggers
  std::size_t axis = 0;                ///< the board's axis (its trigger line)
};

/// What the span measured, once the scan passed B.
struct ScanMeasured {
  double velocity_rad_per_s = 0.0;   ///< (B - A) over the time between the crossings
  double ripple_rad_per_s = 0.0;     ///< standard deviation of the velocity per period
  double ripple_10_rad_per_s = 0.0;  ///< ... of the velocity over ten periods
  double mean_f_hz = 0.0;            ///< the mean drive frequency over the span
  double mean_fraction = 0.0;        ///< the mean amplitude (of V0) over the span
  std::uint32_t periods = 0;         ///< drive periods in the span
};

class ScanController final : public DriveProgram {
 public:
  static constexpr std::size_t kPulseRing = 16384;

  ScanController(const ScanSettings& settings, const PositionFeed& feed);

  double next_voltage(double t, double dt) override;
  [[nodiscard]] bool finished() const override { return stage() == ScanStage::done; }
  [[nodiscard]] StopCause fault() const override;
  [[nodiscard]] std::uint8_t state_code() const override;
  [[nodiscard]] bool stepping() const override;
  void set_neighbours_stepping(bool stepping, double t) override {
    approach_.set_neighbours_stepping(stepping, t);
  }

  // Readable from any thread.
  [[nodiscard]] ScanStage stage() const { return stage_.load(std::memory_order_relaxed); }
  [[nodiscard]] double position_rad() const;
  [[nodiscard]] const ScanSettings& settings() const { return s_; }
  [[nodiscard]] const MoveController& approach() const { return approach_; }
  [[nodiscard]] bool span_measured() const { return measured_ready_.load(); }
  /// Valid once span_measured().
  [[nodiscard]] const ScanMeasured& measured() const { return measured_; }
  [[nodiscard]] std::uint32_t pulses_fired() const { return fired_.load(); }
  [[nodiscard]] std::uint32_t pulses_late() const { return late_.load(); }
  /// Pulses that went out but found the ring to the network thread full.
  [[nodiscard]] std::uint32_t pulses_unreported() const { return unreported_.load(); }
  /// The pulses fired, for the network thread (one reader).
  [[nodiscard]] SpscRing<TriggerPulse>& pulses() { return *pulses_; }
  /// The trigger line back low: called once the drive loop has ended (its
  /// stop may have come while a pulse was high).
  void release_line();

 private:
  void begin_cruise(double t);
  void on_reading(const PositionFeed::Reading& r);
  /// At a period's start: the next period's drive, or the scan's end.
  void next_period(double t);
  [[nodiscard]] double reference_velocity(double t) const;
  void record_period(double t);
  void finish_span();
  void fail(StopCause cause);

  ScanSettings s_;
  const PositionFeed& feed_;
  MoveController approach_;
  PositionCompare compare_;
  double dir_ = 1.0;    ///< +1 from < to
  double rise_ = 0.5;   ///< the sawtooth's rise fraction in the scan's direction
  double lag_s_ = 0.0;  ///< the filtered angle's lag behind the rotor
  // readings
  std::uint64_t seen_ = 0;
  ReadingWindow window_;
  double theta_ = 0.0;  ///< filtered, from the zero
  bool have_theta_ = false;
  double last_theta_ = 0.0;
  std::int64_t last_ns_ = 0;
  // cruise
  double t_cruise_ = 0.0, theta_ref_ = 0.0, v_base_ = 0.0;
  double t_decel_ = -1.0;  ///< when the reference passed B (-1: not yet)
  double cycle_ = 0.0;     ///< within the drive period, 0..1
  VelocityBranch::Drive drive_{};
  double gain_measured_ = 0.0, gain_predicted_ = 0.0;
  double period_start_theta_ = 0.0;
  bool period_start_known_ = false;  ///< the filtered angle was known at the period's start
  // the span
  std::int64_t crossed_a_ns_ = 0, crossed_b_ns_ = 0;
  bool past_a_ = false, past_b_ = false;
  double period_t_ = 0.0, period_theta_ = 0.0;
  std::array<double, 11> ten_t_{}, ten_theta_{};
  std::uint32_t ten_n_ = 0;
  double v1_sum_ = 0.0, v1_sum2_ = 0.0, v10_sum_ = 0.0, v10_sum2_ = 0.0;
  std::uint32_t v1_n_ = 0, v10_n_ = 0;
  double f_sum_ = 0.0, fraction_sum_ = 0.0;
  ScanMeasured measured_;
  std::atomic<bool> measured_ready_{false};
  // triggers
  bool line_high_ = false;
  std::unique_ptr<SpscRing<TriggerPulse>> pulses_;
  std::atomic<std::uint32_t> fired_{0}, late_{0}, unreported_{0};

  StopCause fault_ = StopCause::none;
  std::atomic<StopCause> fault_seen_{StopCause::none};
  std::atomic<ScanStage> stage_{ScanStage::approach};
  std::atomic<double> position_;
};

}  // namespace piezo::firmware
