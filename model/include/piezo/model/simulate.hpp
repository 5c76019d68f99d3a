#pragma once
/// @file
/// Simulation of the motor models: adaptive, error-controlled integration that
/// steps onto every kink of the drive and locates every stick/slip switch.

#include <array>
#include <bitset>
#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model {

enum class FrictionModel { lugre, coulomb };

[[nodiscard]] std::string_view to_string(FrictionModel m);
[[nodiscard]] std::optional<FrictionModel> parse_friction_model(std::string_view text);

/// How the motor's equations are solved.
enum class Integrator {
  model_default,  ///< closed_form for Coulomb, hybrid for LuGre
  dopri5,         ///< adaptive Dormand-Prince 5(4), events located on its dense output
  closed_form,    ///< Coulomb only: exact between switches (coulomb_closed_form.hpp)
  hybrid,         ///< LuGre only: series, linear and stiff modes by event (lugre_hybrid.hpp)
};

[[nodiscard]] std::string_view to_string(Integrator i);
[[nodiscard]] std::optional<Integrator> parse_integrator(std::string_view text);
/// Every friction model's and integrator's name, in order (the CLI's and
/// Python's choices).
[[nodiscard]] std::vector<std::string_view> friction_model_names();
[[nodiscard]] std::vector<std::string_view> integrator_names();

/// Accuracy settings of the adaptive integrator.
/// A trajectory's columns, in their order; t is always recorded (it counts
/// the samples).
inline constexpr std::array<std::string_view, 8> kColumnNames = {"t",     "V",         "x", "x_dot",
                                                                 "theta", "theta_dot", "z", "F_f"};
/// Which columns a run records, by their index in kColumnNames.
using ColumnSet = std::bitset<kColumnNames.size()>;
inline const ColumnSet kAllColumns = ColumnSet{}.set();

struct IntegratorSettings {
  /// Relative and absolute error per step on the scaled state (see simulate.cpp).
  /// The default meets the 1e-4 relative angle requirement with margin; the
  /// convergence tests in tests/model prove it.
  double tolerance = 1e-6;
  Integrator integrator = Integrator::model_default;
  /// DOPRI5 with LuGre: stop at every zero of the sliding velocity (the kink
  /// of |v|) and count them, as the references of the convergence tests do.
  bool reversal_events = false;
  /// Called now and then (at each corner of the drive, and every 32,768
  /// steps within a piece) with the simulated time reached: for progress on
  /// long simulations, and to stop one by throwing; may be empty.
  std::function<void(double t)> progress = {};
  /// The columns recorded: a study that reads theta pays for theta alone
  /// (the others stay empty).
  ColumnSet columns = kAllColumns;
};

/// Cost of a simulation, for benchmarks and for reasoning about tolerances.
struct IntegrationStats {
  std::size_t steps = 0;
  std::size_t rhs_evaluations = 0;
  /// Stick/slip transitions (Coulomb), reversals of the sliding velocity
  /// (LuGre by hybrid, or by dopri5 with reversal_events).
  std::size_t mode_switches = 0;
  /// The hybrid's steps by mode, its closed-form bristle flips and its
  /// rejected stiff steps.
  std::size_t series_steps = 0, linear_steps = 0, stick_steps = 0;
  std::size_t saturations = 0, rejected_steps = 0;
  /// Stretches held stuck through chattering contact (closed form only).
  std::size_t chatter_holds = 0;
  Integrator integrator = Integrator::dopri5;  ///< the one that ran (model_default resolved)
};

/// Samples of a simulated run, one entry per requested time.
struct Trajectory {
  std::vector<double> t, V, x, x_dot, theta, theta_dot, z, F_f;
  /// Times of the Coulomb model's stick/slip switches, in order (empty for LuGre).
  std::vector<double> switch_times;
  IntegrationStats stats;
  ColumnSet columns = kAllColumns;  ///< those recorded (see IntegratorSettings)

  [[nodiscard]] std::size_t size() const { return t.size(); }
  /// Room for n samples in every column recorded, taken once before a run.
  void reserve(std::size_t n);
  /// Empty, recording `kept`: the columns' storage stays, for a caller that
  /// hands a used trajectory to the next run (see simulate()).
  void restart(ColumnSet kept);
  /// One sample: time, voltage, a LuGre or Coulomb state (z is 0 for a
  /// Coulomb state, which has no bristle) and the friction force.
  void append(double t_s, double V_volts, std::span<const double> state, double F_f_value);
};

/// Simulates from rest (all states zero) and samples the state at the given
/// times, which must be non-negative and non-decreasing. For the Coulomb
/// model the z column is zero (it has no bristle state). Throws
/// std::invalid_argument for closed_form with LuGre (its bristle has no
/// closed form). `storage`: a used trajectory whose columns' memory the run
/// writes into (its samples are dropped), so that a loop of runs does not
/// fault in fresh pages each time.
[[nodiscard]] Trajectory simulate(const MotorParameters& p, const Excitation& drive,
                                  FrictionModel model, std::span<const double> sample_times,
                                  const IntegratorSettings& settings = {}, Trajectory storage = {});

/// 0, dt, 2dt, ... up to and including duration (the last interval may be
/// shorter), written into `storage`'s memory (as simulate()'s).
[[nodiscard]] std::vector<double> uniform_times(double duration, double interval,
                                                std::vector<double> storage = {});

/// Rotor angle at t_end only: the cheap call for sweeps.
[[nodiscard]] double final_angle(const MotorParameters& p, const Excitation& drive,
                                 FrictionModel model, double t_end,
                                 const IntegratorSettings& settings = {});

}  // namespace piezo::model
