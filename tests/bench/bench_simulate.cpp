// Simulation throughput at the paper baseline (4.8 s, LuGre and Coulomb,
// 10 and 20 Hz): DOPRI5, and the series (LuGre) or closed form (Coulomb),
// against a plain fixed-step RK4 with a 1 us step, all measured against a
// converged reference.
// Usage: bench_simulate [repeats]   (prints a table; timings are medians)

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "../support/fixed_step_reference.hpp"
#include "../support/median_time.hpp"
#include "piezo/model/simulate.hpp"

using namespace piezo;

using testing::median_seconds;

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  constexpr double kRuntime = 4.8;
  fmt::print("{:<8} {:>5} {:<12} | {:>9} {:>8} {:>9} {:>9} | {:>10} {:>9} | {:>7}\n", "model",
             "f/Hz", "integrator", "time/ms", "sim s/s", "steps", "rel.err", "rk4 1us/ms",
             "rel.err", "speedup");
  for (auto friction : {model::FrictionModel::lugre, model::FrictionModel::coulomb}) {
    for (double f : {10.0, 20.0}) {
      model::Parameters p;
      p.drive.f = f;
      const model::Sawtooth drive(p.drive.V0, f, p.drive.D());
      const double reference =
          model::final_angle(p.motor, drive, friction, kRuntime,
                             {.tolerance = 1e-11, .integrator = model::Integrator::dopri5});
      double rk4 = 0.0;
      const double t_rk4 = median_seconds(repeats, [&] {
        rk4 = friction == model::FrictionModel::lugre
                  ? testing::lugre_rk4_angle(p.motor, drive, kRuntime, 1e-6)
                  : testing::coulomb_rk4_angle(p.motor, drive, kRuntime, 1e-6);
      });
      std::vector<model::Integrator> integrators{model::Integrator::dopri5};
      integrators.push_back(friction == model::FrictionModel::coulomb
                                ? model::Integrator::closed_form
                                : model::Integrator::hybrid);
      for (auto integrator : integrators) {
        const model::IntegratorSettings settings{.integrator = integrator};
        const double times[] = {kRuntime};
        model::Trajectory run;
        const double t_run = median_seconds(
            repeats, [&] { run = model::simulate(p.motor, drive, friction, times, settings); });
        const double angle = run.theta.back();
        fmt::print(
            "{:<8} {:>5g} {:<12} | {:>9.2f} {:>8.0f} {:>9} {:>9.1e} | {:>10.2f} {:>9.1e} | "
            "{:>6.1f}x\n",
            model::to_string(friction), f, model::to_string(integrator), 1e3 * t_run,
            kRuntime / t_run, run.stats.steps, std::abs(angle - reference) / std::abs(reference),
            1e3 * t_rk4, std::abs(rk4 - reference) / std::abs(reference), t_rk4 / t_run);
      }
    }
  }
  fmt::print(
      "reference: dopri5 at tolerance 1e-11; rel.err = |theta - ref| / |ref| at 4.8 s; steps: "
      "accepted steps (dopri5), series steps (taylor) or closed-form pieces between drive corners "
      "and switches\n");
  return 0;
}
