#pragma once
/// @file
/// A closed-loop move to a target angle, run by the drive loop at the
/// sensor's rate (a DriveProgram):
/// - coarse: whole stick-slip steps toward the target, forward or reverse,
///   their amplitude cut near the target; the step per volt starts from a
///   calibration's table or the model's prediction and is corrected from
///   each measured step; forward, the amplitude is also held to the
///   distance left over the angle per volt, so the rotor riding the slow
///   rise stops short of the target;
/// - fine: inside one step, the stator held at a DC voltage (in stick the
///   rotor moves with it: sub-step resolution), integral control on the
///   measured angle; a target behind the rotor is reached by first lifting
///   the stator fast (it slips under the rotor) and then lowering it slowly;
/// - release: the voltage back to 0 V fast, so the stator slips under the
///   rotor and the rotor stays (what the release moves it is learnt and
///   aimed off the next time);
/// - settle: "on target" only once the mean of as many readings as the
///   sensor's noise asks for (measured at rest before the first step, or a
///   calibration's if larger) lies, with its confidence interval, within
///   the tolerance for settle_s at 0 V, so neither oscillating through the
///   target nor the noise counts; a mean clearly outside starts the stages
///   again. The move then ends at 0 V;
/// - approach (forward or reverse): the last coarse steps and the fine
///   servo arrive from that side only; a target on the other side is
///   passed by one full step and approached again, and an
///   overshoot in the fine stage is released and passed the same way;
/// - holding (hold_s > 0, once): on target, the fine servo kept on from the
///   middle of its range for hold_s, then release and settle again;
/// - protection: every `stall_steps` coarse steps the measured progress
///   toward the target is checked against the noise floor. Readings that
///   do not change at all (a frozen sensor), that do not swing while the
///   stator swings (a sensor that does not see the rotor), that move far
///   against the drive, or a step far beyond the predicted one:
///   `sensor_implausible`. No progress, or far less than predicted: the
///   next alternative frequency; none left and no progress: `stalled`.
///   Either ends the run at 0 V with that cause.
/// The parts, each with its own tests: the step model (StepModel), the
/// progress judge (ProgressJudge), the fine servo (FineServo), the settle's
/// mean (SettleMean) and the active hold's record (ActiveHold); this class
/// is the state machine over them.
/// Everything happens inside next_voltage(): no allocation, lock or throw.

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>

#include "piezo/firmware/active_hold.hpp"
#include "piezo/firmware/angle_zero.hpp"
#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/fine_servo.hpp"
#include "piezo/firmware/move_request.hpp"
#include "piezo/firmware/move_state.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/firmware/progress_judge.hpp"
#include "piezo/firmware/settle_mean.hpp"
#include "piezo/firmware/step_model.hpp"
#include "piezo/hal/backend.hpp"
#include "piezo/name_table.hpp"

namespace piezo::firmware {

[[nodiscard]] const char* to_string(MoveState s);

/// What the controller needs: the request (target, tolerance, settle,
/// hold, protection, approach) and the board's plan for it.
struct MoveSettings : MoveRequest {
  /// The board's zero: theta = (d - zero) / r2; NaN: the mean of the
  /// readings at rest before the first step.
  double zero_displacement_m = 0.0;
  double r2_m = hal::kDefaultSensorRadius_m;
  double V0 = 80.0;            ///< coarse step amplitude at most [V]
  double f = 10.0;             ///< coarse step frequency [Hz]
  double D = 0.74955;          ///< forward rise fraction (reverse: 1 - D)
  double rad_per_V = 31.4e-6;  ///< fine: angle per volt in stick, d_e / r
  /// Amplitudes (fractions of V0) at which the step is predicted (step_model.hpp).
  static constexpr auto kStepFractions = firmware::kStepFractions;
  /// The predicted step at each of kStepFractions (magnitudes, rad), from
  /// the model or a fitted config; the controller scales them by what it
  /// measures.
  std::array<double, 6> step_forward_rad{2e-4, 4e-4, 7e-4, 1e-3, 1.2e-3, 1.4e-3};
  std::array<double, 6> step_reverse_rad{2e-4, 4e-4, 7e-4, 1e-3, 1.2e-3, 1.4e-3};
  double fine_V_max = 64.0;           ///< the fine hold's range is [0, fine_V_max]
  double fine_slew_V_per_s = 400.0;   ///< slow enough for the rotor to stick
  double fast_slew_V_per_s = 8000.0;  ///< lift and release: the stator slips under the rotor
  /// Other step frequencies to try when the steps come out far smaller
  /// than predicted (fastest first; from a calibration or the model).
  struct Alternative {
    double f = 0.0;
    std::array<double, 6> forward_rad{}, reverse_rad{};
  };
  static constexpr int kMaxAlternatives = 3;
  std::array<Alternative, kMaxAlternatives> alternatives{};
  int alternative_count = 0;
  /// The sensor's noise as a calibration measured it [m] (NaN: none); the
  /// controller uses the larger of it and what it measures at rest.
  double noise_prior_m = std::numeric_limits<double>::quiet_NaN();
  /// A measured step beyond this many times the model's full step is no
  /// motion of this rotor.
  double implausible_step_factor = 6.0;
};

static_assert(kMaxStallSteps == ProgressJudge::kMaxUnits,
              "a move's stall_steps are the progress judge's units");

class MoveController final : public DriveProgram {
 public:
  MoveController(const MoveSettings& settings, const PositionFeed& feed);

  double next_voltage(double t, double dt) override;
  [[nodiscard]] bool finished() const override { return state() == MoveState::on_target; }
  [[nodiscard]] StopCause fault() const override;
  [[nodiscard]] std::uint8_t state_code() const override {
    return static_cast<std::uint8_t>(state());
  }
  /// Its coarse steps slip the rotor; the fine servo and a hold do not.
  [[nodiscard]] bool stepping() const override { return state() == MoveState::coarse && in_step_; }
  /// While another axis steps, and for settle_s after, this axis's readings
  /// are shaken by it (crosstalk): the fine servo, a hold and the settle do
  /// not correct for them (each correction would chase a disturbance that
  /// passes); the settle starts again once it is quiet.
  void set_neighbours_stepping(bool stepping, double t) override {
    if (stepping) masked_until_ = t + s_.settle_s;
    now_ = t;
  }

  // Readable from any thread while the move runs.
  [[nodiscard]] MoveState state() const { return state_.load(std::memory_order_relaxed); }
  /// The filtered measured angle from the user's zero (NaN before the first reading).
  [[nodiscard]] double position_rad() const { return position_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint32_t steps() const { return steps_.load(std::memory_order_relaxed); }
  /// When the move came on target [s from the time origin] (NaN: not yet).
  [[nodiscard]] double on_target_at_s() const { return on_target_at_.load(); }
  [[nodiscard]] const MoveSettings& settings() const { return s_; }
  /// The zero the move used [m] (NaN until known, when it adopts its own).
  [[nodiscard]] double zero_displacement_m() const { return zero_m_.load(); }
  /// The sensor's noise measured at rest before the first step [m, one
  /// standard deviation of a reading] (NaN until measured).
  [[nodiscard]] double noise_m() const { return noise_m_.load(); }
  /// The frequency the coarse steps use now (changes when the steps come
  /// out far smaller than predicted and another frequency is tried).
  [[nodiscard]] double f_hz() const { return f_.load(); }
  /// The active hold's error: root mean square and largest magnitude of the
  /// averaged angle's distance from the target while holding [rad] (NaN:
  /// no hold).
  [[nodiscard]] double hold_rms_error_rad() const { return hold_.rms_error_rad(); }
  [[nodiscard]] double hold_max_error_rad() const { return hold_.max_error_rad(); }

 private:
  static constexpr int kFilter = ReadingWindow::kSize;  ///< readings averaged
  static constexpr int kFlush = 10;   ///< readings skipped after the rotor was moved
  static constexpr int kSteady = 20;  ///< fine: readings within tolerance/2 before the release
  static constexpr int kNoiseReadings = 16;  ///< at rest, before the first step

  void on_reading(double t, double displacement_m);
  void decide(double t, double error);
  void start_step(double t, double error);
  void learn_from_step();
  void enter_fine(double error);
  /// At each coarse step's end: progress and plausibility (see protection).
  void check_progress();
  void begin_run_of_steps();
  /// The progress judge's floors for the current step.
  [[nodiscard]] ProgressFloors floors() const;
  /// Readings whose mean settles: enough that twice its standard deviation
  /// is at most a quarter of the tolerance (kFilter..SettleMean::kMax).
  [[nodiscard]] int settle_readings() const;
  void settle(double t, double displacement_m);
  void set_state(MoveState s) { state_.store(s, std::memory_order_relaxed); }
  /// The noise the settle and the checks use: measured, or the calibration's if larger.
  [[nodiscard]] double noise() const;
  /// Steps far smaller than predicted: the next alternative frequency.
  [[nodiscard]] bool try_alternative();
  /// +1 forward, -1 reverse: the side every arrival must come from (0: either).
  [[nodiscard]] double approach_side() const;

  /// True while a neighbour's steps shake this rotor (see set_neighbours_stepping).
  [[nodiscard]] bool masked() const { return now_ < masked_until_; }

  MoveSettings s_;
  const PositionFeed& feed_;
  double masked_until_ = -1.0, now_ = 0.0;  ///< the drive thread's alone
  std::uint64_t seen_ = 0;
  ReadingWindow window_;
  double theta_f_ = 0.0;
  int flush_ = 0;
  double V_ = 0.0;
  // coarse
  bool in_step_ = false, step_done_ = false;
  double step_start_ = 0.0, amplitude_ = 0.0, rise_ = 0.0, direction_ = 1.0;
  double predicted_ = 0.0, theta_before_ = 0.0;
  StepModel steps_model_;  ///< the step tables in use, scaled by the measured steps
  // fine: the servo, the aim's offset (what the last release moved the
  // rotor by), and how many readings in a row it has been steady
  FineServo servo_;
  double aim_offset_ = 0.0;
  int steady_ = 0;
  bool released_from_fine_ = false;
  bool wrong_way_ = false;  ///< the last motion went against the approach side
  // settle
  double within_since_ = -1.0;
  SettleMean settle_;
  // protection: the noise at rest, the judge of the current run of steps
  // in one direction, and the raw angle's extremes during the step
  double noise_sum_ = 0.0, noise_sum2_ = 0.0;
  int noise_n_ = 0;
  ProgressJudge judge_;
  double step_low_ = 0.0, step_high_ = 0.0;
  int next_alternative_ = 0;
  // active hold (once a move)
  bool held_ = false;
  ActiveHold hold_;

  std::atomic<MoveState> state_{MoveState::coarse};
  AngleZero zero_;              ///< the move's frame (the drive loop's own)
  std::atomic<double> zero_m_;  ///< the same, for the network thread
  std::atomic<double> noise_m_;
  std::atomic<double> position_;
  std::atomic<std::uint32_t> steps_{0};
  std::atomic<double> on_target_at_;
  std::atomic<double> f_;
};

}  // namespace piezo::firmware
