#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "piezo/model/lugre_observer.hpp"
#include "piezo/model/sampled_drive.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {
namespace {

// Measurements of a "true" motor at 1 kHz with 8 urad noise, the drive
// commanded at 10 kHz; the observer starts 5 mrad and 2 mrad/s off.
struct Scenario {
  Parameters truth;
  std::vector<double> t, theta;
  Sawtooth drive{80.0, 10.0, 0.95 * 0.789};
  static constexpr double kNoise = 8e-6;

  explicit Scenario(const Parameters& p) : truth(p) {
    // The truth sees the commands as the observer does: 10 kHz samples,
    // each reached over one period.
    std::vector<double> t_cmd, V_cmd;
    for (int k = 0; k <= 20'000; ++k) {
      t_cmd.push_back(k * 1e-4);
      V_cmd.push_back(drive.voltage(k * 1e-4));
    }
    t = uniform_times(2.0, 1e-3);
    theta = simulate(p.motor, SampledDrive(t_cmd, V_cmd, 1e-4), FrictionModel::lugre, t).theta;
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, kNoise);
    for (double& th : theta) th += noise(rng);
  }

  /// Residuals of an observer of `model` run over the measurements.
  std::vector<double> residuals(const MotorParameters& model, const ObserverGains& gains,
                                const LuGreState& initial) const {
    LuGreObserver observer(model, gains, 1e-4, 0.0, initial);
    std::vector<double> out;
    double t_cmd = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      for (; t_cmd <= t[i] + 1e-9; t_cmd += 1e-4) observer.command(t_cmd, drive.voltage(t_cmd));
      out.push_back(observer.measure(t[i], theta[i]));
    }
    return out;
  }
};

double rms(const std::vector<double>& v, std::size_t from) {
  double s = 0;
  for (std::size_t i = from; i < v.size(); ++i) s += v[i] * v[i];
  return std::sqrt(s / static_cast<double>(v.size() - from));
}

TEST(LuGreObserver, ConvergesFromAWrongInitialState) {
  const Scenario s{Parameters{}};
  LuGreState wrong{};
  wrong[kTheta] = 5e-3;
  wrong[kThetaDot] = 2e-3;
  const auto r = s.residuals(s.truth.motor, {}, wrong);
  EXPECT_GT(std::abs(r.front()), 4e-3) << "starts off";
  EXPECT_LT(rms(r, 100), 2 * Scenario::kNoise) << "after 0.1 s only the noise is left";
}

TEST(LuGreObserver, TracksAMismatchedPlantFarBetterThanTheOpenLoopModel) {
  Parameters plant;
  plant.motor.mu = 0.12;
  plant.motor.sigma0 = 2000;
  const Scenario s{plant};
  const MotorParameters model;  // Table 1, not the plant
  const double corrected = rms(s.residuals(model, {}, {}), 0);
  const double open_loop = rms(s.residuals(model, {0.0, 0.0}, {}), 0);
  EXPECT_LT(corrected, 3 * Scenario::kNoise);
  EXPECT_GT(open_loop, 20 * corrected) << "corrected " << corrected << ", open loop " << open_loop;
}

TEST(LuGreObserver, WithZeroGainsItIsTheModel) {
  const Scenario s{Parameters{}};
  const auto r = s.residuals(s.truth.motor, {0.0, 0.0}, {});
  EXPECT_LT(rms(r, 0), 2 * Scenario::kNoise);
}

}  // namespace
}  // namespace piezo::model
