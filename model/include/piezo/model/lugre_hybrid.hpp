#pragma once
/// @file
/// The LuGre motor by an event-driven hybrid integrator (issue 23): each
/// stretch of the motion is advanced by the method that suits it.
///
/// - Series mode (the ringing after each drive corner, and bristle flips):
///   Taylor series of order 14 between events, zeros of the sliding
///   velocity v located on the series (hybrid/series.hpp).
/// - Linear mode (sliding with a saturated bristle): the closed-form finish
///   of the bristle's flip, then the exact propagator of the then linear
///   motor in fixed steps while the smooth part of v stays clear of the
///   ringing (hybrid/linear_slide.hpp).
/// - Stick mode (bristle far from saturation, ringing died away): the stiff
///   stick phase by a Rosenbrock method (hybrid/stick_rosenbrock.hpp).
///
/// Every drive corner (every advance) restarts in series mode. Samples come
/// from the series, or from cubic Hermite interpolation between the other
/// modes' steps. Allocation-free.

#include <functional>
#include <limits>
#include <span>

#include "piezo/model/hybrid/linear_slide.hpp"
#include "piezo/model/hybrid/series.hpp"
#include "piezo/model/hybrid/state_cubic.hpp"
#include "piezo/model/hybrid/stick_rosenbrock.hpp"
#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model {

/// Receives the state at the times it asks for during an advance.
class StateSamples {
 public:
  /// The next time wanted (infinity: none): a plain read, as the
  /// integrator asks it before each sample and at each step.
  [[nodiscard]] double next() const { return next_; }
  /// The state at next() and the drive's voltage there (from the piece the
  /// integrator is on: no lookup in the drive per sample); the sink moves
  /// on to its following time (set_next).
  virtual void take(const LuGreState& y, double V) = 0;
  /// The samples up to t1 between two steps, from the state's cubic there
  /// and the drive's piece (most of a run's samples: a step's worth at a
  /// time).
  virtual void take_from(const hybrid::StateCubic& cubic, const LinearPiece& piece, double t1) = 0;

 protected:
  ~StateSamples() = default;
  void set_next(double t) { next_ = t; }

 private:
  double next_ = std::numeric_limits<double>::infinity();
};

/// The LuGre motor advanced piece by piece of drive, from a given state.
class LuGreHybrid {
 public:
  /// @param tolerance the error per step relative to each state's scale
  explicit LuGreHybrid(const MotorParameters& p, double tolerance = 1e-6);

  /// Restarts at time t in state y.
  void reset(double t, const LuGreState& y);

  /// Advances to t_end with the voltage following `piece`, handing
  /// `samples` (if any) the state at each time it asks for up to t_end.
  void advance(const LinearPiece& piece, double t_end, StateSamples* samples = nullptr);

  /// Calls `progress` with the time reached every kStepsBetweenProgress
  /// steps inside advance(): a stiff parameter set can take millions of
  /// steps within one piece of drive, and the caller must still be able to
  /// show how far it is and to stop the work (by throwing from `progress`).
  /// The function must outlive the motor's use; an empty one is not called.
  void report_progress(const std::function<void(double t)>& progress) { progress_ = &progress; }
  static constexpr std::size_t kStepsBetweenProgress = 1 << 15;

  [[nodiscard]] const LuGreState& state() const { return y_; }
  [[nodiscard]] double time() const { return t_; }
  [[nodiscard]] const IntegrationStats& stats() const { return stats_; }

 private:
  enum class Mode { series, linear, stick };
  /// One step in the mode in force; false when the mode must change first.
  void series_step(const LinearPiece& piece, double t_end, StateSamples* samples);
  void expand(const LinearPiece& piece);
  bool linear_step(const LinearPiece& piece, double t_end, StateSamples* samples);
  bool stick_step(const LinearPiece& piece, double t_end, StateSamples* samples);
  /// After a series step: the mode the motion has entered.
  void choose_mode(const LinearPiece& piece, double t_end, bool crawling);
  /// Hands out the samples in (t_, t1] by Hermite interpolation to y1.
  void interpolate(StateSamples* samples, const LinearPiece& piece, double t1,
                   const LuGreState& y1) const;

  MotorParameters p_;
  LuGreMotor motor_;
  hybrid::SeriesMotor series_;
  hybrid::StickRosenbrock stick_;
  hybrid::LinearSlide slide_;
  LuGreState inverse_scale_;  ///< 1 / each state's scale, for the series step bound
  double tolerance_, omega_n_, kappa_;
  /// The stator settled at stick entry and the flip in closed form: off at
  /// tolerances tighter than their error.
  bool approximate_;

  double t_ = 0.0;
  LuGreState y_{};
  double s_ = 0.0;          ///< the sliding sign; 0: to be found at the next step
  bool saturated_ = false;  ///< the bristle held at s/kappa until v reverses
  bool stiff_ = false;      ///< in stick mode because the series crawled, not because it sticks
  bool settle_ = false;     ///< the stick mode's first step settles the stator's ringing
  Mode mode_ = Mode::series;
  double stick_h_ = 0.0;          ///< the Rosenbrock's next step
  double no_stick_before_ = 0.0;  ///< after a stick step that met a reversal
  double ringing_ = 0.0;          ///< the stator's ringing amplitude at the step's start [m/s]
  hybrid::Expansion e_{};
  IntegrationStats stats_{};
  const std::function<void(double)>* progress_ = nullptr;
  std::size_t progress_at_step_ = kStepsBetweenProgress;
};

/// Simulates the LuGre motor from rest (see simulate()).
[[nodiscard]] Trajectory simulate_lugre_hybrid(const MotorParameters& p, const Excitation& drive,
                                               std::span<const double> sample_times,
                                               const IntegratorSettings& settings,
                                               Trajectory storage = {});

}  // namespace piezo::model
