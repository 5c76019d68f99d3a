// Simulation throughput at the paper baseline (4.8 s, LuGre and Coulomb,
// 10 and 20 Hz): the default adaptive integrator against a plain fixed-step
// RK4 with a 1 us step, both measured against a converged reference.
// Usage: bench_simulate [repeats]   (prints a table; timings are medians)

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <vector>

#include "../support/fixed_step_reference.hpp"
#include "piezo/model/simulate.hpp"

using namespace piezo;

namespace {

double median_seconds(int repeats, const std::function<double()>& run, double& result) {
  std::vector<double> times;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    result = run();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  constexpr double kRuntime = 4.8;
  fmt::print("{:<8} {:>5} | {:>11} {:>10} {:>9} | {:>11} {:>10} | {:>7}\n", "model", "f/Hz",
             "adaptive/ms", "sim s/s", "rel.err", "rk4 1us/ms", "rel.err", "speedup");
  for (auto friction : {model::FrictionModel::lugre, model::FrictionModel::coulomb}) {
    for (double f : {10.0, 20.0}) {
      model::Parameters p;
      p.drive.f = f;
      const model::Sawtooth drive(p.drive.V0, f, p.drive.D());
      const double reference =
          model::final_angle(p.motor, drive, friction, kRuntime, {.tolerance = 1e-11});
      double adaptive = 0.0, rk4 = 0.0;
      const double t_adaptive = median_seconds(
          repeats, [&] { return model::final_angle(p.motor, drive, friction, kRuntime); },
          adaptive);
      const double t_rk4 = median_seconds(
          repeats,
          [&] {
            return friction == model::FrictionModel::lugre
                       ? testing::lugre_rk4_angle(p.motor, drive, kRuntime, 1e-6)
                       : testing::coulomb_rk4_angle(p.motor, drive, kRuntime, 1e-6);
          },
          rk4);
      fmt::print("{:<8} {:>5g} | {:>11.2f} {:>10.1f} {:>9.1e} | {:>11.2f} {:>10.1e} | {:>6.1f}x\n",
                 model::to_string(friction), f, 1e3 * t_adaptive, kRuntime / t_adaptive,
                 std::abs(adaptive - reference) / std::abs(reference), 1e3 * t_rk4,
                 std::abs(rk4 - reference) / std::abs(reference), t_rk4 / t_adaptive);
    }
  }
  fmt::print(
      "reference: adaptive dopri5 at tolerance 1e-11; rel.err = |theta - ref| / |ref| at 4.8 s\n");
  return 0;
}
