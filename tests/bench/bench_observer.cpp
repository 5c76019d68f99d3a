// Bench: the observer's cost per drive sample and per sensor sample, and
// the wall time of identifying the LuGre parameters on a 4.9 s log.
// Usage: bench_observer

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <random>

#include "jobs/parallel.hpp"
#include "piezo/model/identify.hpp"
#include "piezo/model/lugre_hybrid.hpp"
#include "piezo/model/lugre_integrator.hpp"
#include "piezo/model/lugre_observer.hpp"

namespace {

using namespace piezo;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main() {
  const model::Parameters p;
  const model::Sawtooth saw(p.drive.V0, p.drive.f, p.drive.D());
  constexpr double kDuration = 4.9;

  // A 4.9 s log: drive at 10 kHz, angle at 1 kHz with 8 urad noise.
  model::FitData log;
  for (int k = 0; k * 1e-4 <= kDuration + 1e-9; ++k) {
    log.drive_t.push_back(k * 1e-4);
    log.drive_V.push_back(saw.voltage(k * 1e-4));
  }
  log.ramp_time = 1e-4;
  log.t = model::uniform_times(kDuration, 1e-3);
  model::Parameters truth = p;
  truth.motor.sigma0 = 2100;
  truth.motor.F_N = 5.4e-3;
  truth.motor.d_e = 0.5e-6;
  log.theta = model::predict(truth, log, model::FrictionModel::lugre, 1e-9);
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 8e-6);
  for (double& th : log.theta) th += noise(rng);

  // Observer: commands alone, then commands with measurements.
  {
    model::LuGreObserver observer(p.motor, {}, 1e-4);
    const auto start = Clock::now();
    for (std::size_t k = 0; k < log.drive_t.size(); ++k)
      observer.command(log.drive_t[k], log.drive_V[k]);
    const double per_drive = seconds_since(start) / static_cast<double>(log.drive_t.size());

    model::LuGreObserver corrected(p.motor, {}, 1e-4);
    std::size_t k = 0;
    const auto start2 = Clock::now();
    for (std::size_t i = 0; i < log.t.size(); ++i) {
      for (; k < log.drive_t.size() && log.drive_t[k] <= log.t[i]; ++k) {
        corrected.command(log.drive_t[k], log.drive_V[k]);
      }
      (void)corrected.measure(log.t[i], log.theta[i]);
    }
    const double total = seconds_since(start2);
    const double per_sensor =
        (total - per_drive * static_cast<double>(k)) / static_cast<double>(log.t.size());
    fmt::print(
        "observer: {:.2f} us per drive sample (10 kHz: {:.1f} % of one core), "
        "{:.2f} us per sensor sample\n",
        1e6 * per_drive, 100 * per_drive * 1e4, 1e6 * per_sensor);
  }

  // The plant's and the observer's way: the motor advanced one piece of
  // drive per write (a 0.1 ms ramp to each 10 kHz sample), by DOPRI5
  // (LuGreIntegrator) and by the hybrid (LuGreHybrid), at the tolerance the
  // plant uses.
  {
    auto per_sample = [&](auto& motor) {
      motor.reset(0.0, model::LuGreState{});
      const auto start = Clock::now();
      double V = 0.0;
      for (std::size_t k = 0; k + 1 < log.drive_t.size(); ++k) {
        const double t0 = log.drive_t[k], t1 = log.drive_t[k + 1];
        const double slope = (log.drive_V[k] - V) / (t1 - t0);
        motor.advance(model::LinearPiece{t0, V, slope}, t1);
        V = log.drive_V[k];
      }
      return seconds_since(start) / static_cast<double>(log.drive_t.size() - 1);
    };
    model::LuGreIntegrator dopri5(p.motor);
    model::LuGreHybrid hybrid(p.motor);
    const double t_dopri5 = per_sample(dopri5), t_hybrid = per_sample(hybrid);
    fmt::print(
        "motor piece by piece (10 kHz writes, {} s): dopri5 {:.3f} us per sample, hybrid {:.3f} "
        "us ({:.2f}x); angles at the end differ by {:.2e} rad of {:.4f}\n",
        kDuration, 1e6 * t_dopri5, 1e6 * t_hybrid, t_dopri5 / t_hybrid,
        std::abs(dopri5.state()[model::kTheta] - hybrid.state()[model::kTheta]),
        hybrid.state()[model::kTheta]);
  }

  // Identification of sigma0, sigma1, F_N, d_e from Table 1 values.
  model::FitSettings settings;
  settings.for_each = [](std::size_t n, const std::function<void(std::size_t)>& job) {
    host::parallel_for(n, job, [](std::size_t, std::size_t) {});
  };
  const auto start = Clock::now();
  const model::FitResult r = model::identify(p, log, settings);
  fmt::print(
      "identify on a {} s log ({} samples): {:.1f} s wall, {} iterations, RMSE {:.2f} urad\n",
      kDuration, log.t.size(), seconds_since(start), r.iterations, 1e6 * r.rmse_rad);
  {
    const auto at_truth =
        model::predict(truth, log, model::FrictionModel::lugre, settings.tolerance);
    double sum_sq = 0;
    for (std::size_t i = 0; i < at_truth.size(); ++i)
      sum_sq += std::pow(at_truth[i] - log.theta[i], 2);
    fmt::print("  RMSE at the true parameters: {:.4f} urad (fit: {:.4f} urad)\n",
               1e6 * std::sqrt(sum_sq / static_cast<double>(at_truth.size())), 1e6 * r.rmse_rad);
  }
  for (const auto& f : r.fitted) {
    fmt::print("  {:<7} {:.5g} +- {:.2g} (true {:.5g})\n", f.name, f.value, f.standard_error,
               *model::get_parameter(truth, f.name));
  }
  return 0;
}
