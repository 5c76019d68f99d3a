#include "piezo/model/identify.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace piezo::model {
namespace {

constexpr double kNoise = 8e-6;  // rad: 0.5 um at r2 = 62 mm

/// A synthetic log: the sawtooth commanded at 10 kHz, the angle measured at
/// 500 Hz with white noise, from a motor with parameters `truth`.
FitData synthetic_log(const Parameters& truth, double duration, unsigned seed) {
  FitData d;
  const Sawtooth saw(truth.drive.V0, truth.drive.f, truth.drive.D());
  for (double t = 0.0; t <= duration + 1e-9; t += 1e-4) {
    d.drive_t.push_back(t);
    d.drive_V.push_back(saw.voltage(t));
  }
  d.ramp_time = 1e-4;
  d.t = uniform_times(duration, 2e-3);
  d.theta = predict(truth, d, FrictionModel::lugre);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, kNoise);
  for (double& th : d.theta) th += noise(rng);
  return d;
}

Parameters true_motor() {
  Parameters p;
  p.motor.sigma0 = 2100;
  p.motor.sigma1 = 30;
  p.motor.F_N = 5.4e-3;
  p.motor.d_e = 0.5e-6;
  return p;
}

class Identify : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = true_motor();
    data_ = synthetic_log(truth_, 1.0, 11);
    result_ = identify(Parameters{}, data_);  // starts from Table 1
  }
  static Parameters truth_;
  static FitData data_;
  static FitResult result_;
};
Parameters Identify::truth_;
FitData Identify::data_;
FitResult Identify::result_;

TEST_F(Identify, RecoversEachParameterWithinItsConfidenceInterval) {
  ASSERT_EQ(result_.fitted.size(), 4u);
  for (const auto& f : result_.fitted) {
    const double true_value = *get_parameter(truth_, f.name);
    EXPECT_GE(true_value, f.low95) << f.name << " = " << f.value << " +- " << f.standard_error;
    EXPECT_LE(true_value, f.high95) << f.name << " = " << f.value << " +- " << f.standard_error;
    EXPECT_GT(f.standard_error, 0.0);
  }
  EXPECT_GT(result_.initial_rmse_rad, 10 * kNoise) << "Table 1 is far from the truth";
  EXPECT_LT(result_.rmse_rad, 1.2 * kNoise) << "only the noise is left";
}

TEST_F(Identify, PredictsAHeldOutRunAtAnotherFrequencyAndVoltage) {
  Parameters other = truth_;
  other.drive.f = 15.0;
  other.drive.V0 = 70.0;
  const FitData held_out = synthetic_log(other, 0.6, 23);
  Parameters fitted = result_.parameters;
  fitted.drive = other.drive;
  const auto predicted = predict(fitted, held_out, FrictionModel::lugre);
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < predicted.size(); ++i) {
    sum_sq += std::pow(predicted[i] - held_out.theta[i], 2);
  }
  const double rmse = std::sqrt(sum_sq / static_cast<double>(predicted.size()));
  EXPECT_LT(rmse, 2 * kNoise);
  const auto table1 = predict(Parameters{}, held_out, FrictionModel::lugre);
  double sum_sq_table1 = 0.0;
  for (std::size_t i = 0; i < table1.size(); ++i) {
    sum_sq_table1 += std::pow(table1[i] - held_out.theta[i], 2);
  }
  EXPECT_GT(std::sqrt(sum_sq_table1 / static_cast<double>(table1.size())), 8 * rmse)
      << "the fit predicts the held-out run several times better than Table 1";
}

TEST(IdentifyNotes, MuAndNormalForceAreNotSeparatelyIdentifiable) {
  const FitData data = synthetic_log(Parameters{}, 0.3, 3);
  FitSettings settings;
  settings.free = {"mu", "F_N"};
  settings.max_iterations = 3;
  const FitResult r = identify(Parameters{}, data, settings);
  // Among the notes (a fit cut at three iterations may also say it did not
  // converge, first).
  EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& note) {
    return note.find("only as their product") != std::string::npos;
  }));
}

TEST(IdentifyNotes, RefusesUnknownParameters) {
  const FitData data = synthetic_log(Parameters{}, 0.1, 3);
  FitSettings settings;
  settings.free = {"sigma3"};
  EXPECT_THROW((void)identify(Parameters{}, data, settings), std::invalid_argument);
}

}  // namespace
}  // namespace piezo::model
