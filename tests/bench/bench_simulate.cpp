// Simulation throughput at the paper baseline, 4.8 s per run, one run of
// this program, side by side: the LuGre model by the hybrid integrator (the
// default), by DOPRI5 and by a plain fixed-step RK4 with a 1 us step, at 5,
// 10, 20, 50, 200 and 2000 Hz; the Coulomb model by DOPRI5 and in closed
// form at 10 and 20 Hz. Errors against a converged reference (DOPRI5 at
// 1e-11 stopping at every zero of v). Then the hybrid's cost broken down by
// mode: steps per mode at 10 and 20 Hz times each mode's cost per step,
// measured here on states taken from the run. Last, the hybrid's error
// against the tolerance asked, 1e-4 to 1e-10, at 5, 10, 20 and 50 Hz.
// Usage: bench_simulate [repeats]   (prints tables; timings are medians, of runs
// interleaved where they are set side by side)

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "../support/fixed_step_reference.hpp"
#include "../support/median_time.hpp"
#include "piezo/model/hybrid/linear_slide.hpp"
#include "piezo/model/hybrid/ringing.hpp"
#include "piezo/model/hybrid/series.hpp"
#include "piezo/model/hybrid/stick_rosenbrock.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/step_control.hpp"

using namespace piezo;

using testing::median_seconds;

namespace {

constexpr double kRuntime = 4.8;

double relative(double value, double reference) {
  return std::abs(value - reference) / std::abs(reference);
}

model::Trajectory run(const model::Parameters& p, model::FrictionModel friction,
                      model::Integrator integrator, double tolerance = 1e-6, bool events = false) {
  const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const double times[] = {kRuntime};
  return model::simulate(
      p.motor, drive, friction, times,
      {.tolerance = tolerance, .integrator = integrator, .reversal_events = events});
}

/// The hybrid's per-step cost in each mode, on states of a 10 Hz run.
struct ModeCosts {
  double series_us, linear_us, stick_us;
};

ModeCosts mode_costs(const model::Parameters& p, int repeats) {
  const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  // 1 ms after the rise corner (ringing), 40 ms (sticking), 90 ms (sliding).
  const double T = 1.0 / p.drive.f;
  const double times[] = {10 * T + 1e-3, 10 * T + 0.4 * T, 10 * T + 0.9 * T};
  const model::Trajectory tr = model::simulate(p.motor, drive, model::FrictionModel::lugre, times);
  auto state = [&](std::size_t i) {
    return model::LuGreState{tr.x[i], tr.x_dot[i], tr.theta[i], tr.theta_dot[i], tr.z[i]};
  };
  constexpr int kCalls = 20000;
  const model::LuGreState scale = model::state_scale<5>(p.motor);
  const model::LuGreState inverse_scale = model::hybrid::inverse(scale);
  const double omega_n = std::sqrt(p.motor.K / p.motor.M);
  double sink = 0.0;

  const model::hybrid::SeriesMotor series(p.motor);
  model::hybrid::Expansion e{};
  const model::LuGreState ringing = state(0);
  const double v0 = ringing[model::kXDot] - p.motor.r * ringing[model::kThetaDot];
  const double s = v0 >= 0.0 ? 1.0 : -1.0;
  const double t_series = median_seconds(repeats, [&] {
    for (int i = 0; i < kCalls; ++i) {
      series.expand(ringing, tr.V[0], drive.piece(times[0]).slope, s, false, e);
      const double h = model::hybrid::allowed_step(e, inverse_scale, 1e-6, 4.0 / omega_n);
      const double tau = model::hybrid::first_zero(e.v, s, h);
      sink += e.state(tau)[model::kTheta];
    }
  });

  model::LuGreState atol = scale;
  for (double& a : atol) a *= 1e-6;
  const model::hybrid::StickRosenbrock stick(p.motor, atol, 1e-6);
  const model::LuGreState sticking = state(1);
  model::LuGreState out{};
  const double t_stick = median_seconds(repeats, [&] {
    for (int i = 0; i < kCalls; ++i) {
      sink += stick.step(sticking, tr.V[1], drive.piece(times[1]).slope, 1.0, 2e-3, out);
    }
  });

  model::hybrid::LinearSlide slide(p.motor, 16.0 / omega_n);
  const model::LuGreState sliding = state(2);
  const double slope = drive.piece(times[2]).slope;
  const double t_linear = median_seconds(repeats, [&] {
    model::LuGreState y = sliding;  // chained, so that no step can be hoisted
    for (int i = 0; i < kCalls; ++i) {
      slide.advance(y, tr.V[2], slope, -1.0);
      sink += model::hybrid::split_ringing(p.motor, y, tr.V[2], slope, -p.motor.F_c()).amplitude;
    }
  });
  if (sink == 1.2345) std::abort();  // keeps the loops from being optimised away
  return {1e6 * t_series / kCalls, 1e6 * t_linear / kCalls, 1e6 * t_stick / kCalls};
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  fmt::print("LuGre, {} s at the baseline; rel.err = |theta - ref| / |ref| at the end\n", kRuntime);
  fmt::print("{:>6} | {:>9} {:>8} {:>9} | {:>9} {:>8} {:>8} | {:>9} {:>8} | {:>7} {:>7}\n", "f/Hz",
             "hybrid/ms", "steps", "rel.err", "dopri5/ms", "steps", "rel.err", "rk4 1us/ms",
             "rel.err", "vs rk4", "vs dp5");
  struct Row {
    double f;
    model::IntegrationStats stats;
    double ms;
  };
  std::vector<Row> rows;
  for (double f : {5.0, 10.0, 20.0, 50.0, 200.0, 2000.0}) {
    model::Parameters p;
    p.drive.f = f;
    const model::Sawtooth drive(p.drive.V0, f, p.drive.D());
    const double reference =
        run(p, model::FrictionModel::lugre, model::Integrator::dopri5, 1e-11, true).theta.back();
    double rk4 = 0.0;
    model::Trajectory hybrid, dopri5;
    const auto medians = testing::interleaved_median_seconds(
        repeats,
        {[&] { rk4 = testing::lugre_rk4_angle(p.motor, drive, kRuntime, 1e-6); },
         [&] { hybrid = run(p, model::FrictionModel::lugre, model::Integrator::hybrid); },
         [&] { dopri5 = run(p, model::FrictionModel::lugre, model::Integrator::dopri5); }});
    const double t_rk4 = medians[0], t_hybrid = medians[1], t_dopri5 = medians[2];
    fmt::print(
        "{:>6g} | {:>9.2f} {:>8} {:>9.1e} | {:>9.2f} {:>8} {:>8.1e} | {:>9.1f} {:>8.1e} | "
        "{:>6.1f}x {:>6.1f}x\n",
        f, 1e3 * t_hybrid, hybrid.stats.steps, relative(hybrid.theta.back(), reference),
        1e3 * t_dopri5, dopri5.stats.steps, relative(dopri5.theta.back(), reference), 1e3 * t_rk4,
        relative(rk4, reference), t_rk4 / t_hybrid, t_dopri5 / t_hybrid);
    rows.push_back({f, hybrid.stats, 1e3 * t_hybrid});
  }

  fmt::print("\nCoulomb, {} s at the baseline\n", kRuntime);
  fmt::print("{:>6} | {:>12} {:>9} {:>8} {:>9} | {:>9} {:>8}\n", "f/Hz", "integrator", "time/ms",
             "steps", "rel.err", "rk4 1us/ms", "speedup");
  for (double f : {10.0, 20.0}) {
    model::Parameters p;
    p.drive.f = f;
    const model::Sawtooth drive(p.drive.V0, f, p.drive.D());
    const double reference =
        run(p, model::FrictionModel::coulomb, model::Integrator::dopri5, 1e-11).theta.back();
    double rk4 = 0.0;
    const double t_rk4 = median_seconds(
        repeats, [&] { rk4 = testing::coulomb_rk4_angle(p.motor, drive, kRuntime, 1e-6); });
    for (auto integrator : {model::Integrator::dopri5, model::Integrator::closed_form}) {
      model::Trajectory r;
      const double t =
          median_seconds(repeats, [&] { r = run(p, model::FrictionModel::coulomb, integrator); });
      fmt::print("{:>6g} | {:>12} {:>9.2f} {:>8} {:>9.1e} | {:>9.1f} {:>7.1f}x\n", f,
                 model::to_string(integrator), 1e3 * t, r.stats.steps,
                 relative(r.theta.back(), reference), 1e3 * t_rk4, t_rk4 / t);
    }
  }

  const ModeCosts cost = mode_costs(model::Parameters{}, repeats);
  fmt::print("\nseries step: {:.3f} us (expansion, step bound, zero search, state at its end)\n",
             cost.series_us);
  fmt::print(
      "Hybrid cost by mode (per step: series {:.3f} us, linear {:.3f} us, stick {:.3f} us "
      "incl. its LU)\n",
      cost.series_us, cost.linear_us, cost.stick_us);
  fmt::print("{:>6} | {:>8} {:>8} {:>8} {:>8} {:>6} | {:>9} {:>9} {:>9} | {:>8} {:>9}\n", "f/Hz",
             "series", "linear", "stick", "rejected", "flips", "series/ms", "linear/ms", "stick/ms",
             "sum/ms", "measured");
  for (const Row& r : rows) {
    const double series = 1e-3 * cost.series_us * static_cast<double>(r.stats.series_steps);
    const double linear = 1e-3 * cost.linear_us * static_cast<double>(r.stats.linear_steps);
    const double stick =
        1e-3 * cost.stick_us * static_cast<double>(r.stats.stick_steps + r.stats.rejected_steps);
    fmt::print(
        "{:>6g} | {:>8} {:>8} {:>8} {:>8} {:>6} | {:>9.2f} {:>9.2f} {:>9.2f} | {:>8.2f} {:>9.2f}\n",
        r.f, r.stats.series_steps, r.stats.linear_steps, r.stats.stick_steps,
        r.stats.rejected_steps, r.stats.saturations, series, linear, stick, series + linear + stick,
        r.ms);
  }
  fmt::print(
      "reversals of v (10 Hz): {}; steps: series steps, linear steps and Rosenbrock steps "
      "(hybrid), accepted steps (dopri5), closed-form pieces (Coulomb); flips: bristle "
      "saturations finished in closed form\n",
      rows[1].stats.mode_switches);

  // What simulate()'s samples cost beside the integration (what
  // piezo_rig.model.simulate() adds NumPy to; bench_simulate_python.py
  // measures that call itself): 48,001 samples of every column, of theta
  // alone, and the end alone.
  {
    const model::Parameters p;
    const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
    const auto every = model::uniform_times(kRuntime, 1e-4);
    const double end[] = {kRuntime};
    model::ColumnSet theta_only;
    theta_only.set(0).set(4);
    model::Trajectory reused;
    auto timed = [&](std::span<const double> times, const model::ColumnSet& columns) {
      return [&, times, columns] {
        reused = model::simulate(p.motor, drive, model::FrictionModel::lugre, times,
                                 {.columns = columns}, std::move(reused));
      };
    };
    const auto medians = testing::interleaved_median_seconds(
        repeats, {timed(end, model::kAllColumns), timed(every, model::kAllColumns),
                  timed(every, theta_only)});
    const double alone = medians[0], all = medians[1], theta = medians[2];
    fmt::print(
        "\nSamples, 10 Hz, {} of them (storage reused): every column {:.2f} ms, theta alone "
        "{:.2f} ms, the end alone (the integration) {:.2f} ms: {:.2f}x and {:.2f}x\n",
        every.size(), 1e3 * all, 1e3 * theta, 1e3 * alone, all / alone, theta / alone);
  }

  // Does the hybrid converge? Its error against the tolerance asked, down
  // to where an approximation in it (the stator settled at stick entry,
  // the bristle's flip in closed form) leaves a floor.
  fmt::print("\nHybrid: rel. error of theta(4.8 s) against the tolerance asked\n{:>6} |", "f/Hz");
  const double tolerances[] = {1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10};
  for (const double tol : tolerances) fmt::print(" {:>8.0e}", tol);
  fmt::print("\n");
  for (const double f : {5.0, 10.0, 20.0, 50.0}) {
    model::Parameters p;
    p.drive.f = f;
    const double reference =
        run(p, model::FrictionModel::lugre, model::Integrator::dopri5, 1e-11, true).theta.back();
    fmt::print("{:>6g} |", f);
    for (const double tol : tolerances) {
      const double theta =
          run(p, model::FrictionModel::lugre, model::Integrator::hybrid, tol).theta.back();
      fmt::print(" {:>8.1e}", relative(theta, reference));
    }
    fmt::print("\n");
  }
  return 0;
}
