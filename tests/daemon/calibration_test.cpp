// The board's calibration record without a board: built from an
// experiment's result, checked on the way in (each refusal naming its
// key), applied to a move, and kept in a file that survives a round trip.

#include "daemon/calibration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "../support/run_command.hpp"
#include "piezo/protocol/error.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;

const CalibrationLimits kLimits{80.0, 500.0};

/// An experiment at 10 and 20 Hz whose steps grow with the amplitude.
protocol::CalibrationRecord measured() {
  firmware::CalibrationPlan plan;
  plan.frequencies = 2;
  firmware::CalibrationResult r;
  r.noise_m = 0.5e-6;
  r.rad_per_V = 31.4e-6;
  for (int fi = 0; fi < 2; ++fi) {
    for (int a = 0; a < firmware::CalibrationPlan::kFractions; ++a) {
      const double step = (fi + 1) * 2e-4 * (a + 1);
      r.forward_rad[static_cast<std::size_t>(fi)][static_cast<std::size_t>(a)] = step;
      r.reverse_rad[static_cast<std::size_t>(fi)][static_cast<std::size_t>(a)] = -step;
    }
  }
  r.complete = true;
  return measured_calibration(plan, r);
}

std::string refusal_key(const json& c) {
  try {
    (void)checked_calibration(c, kLimits);
  } catch (const protocol::ProtocolError& e) {
    return e.key();
  }
  return "";
}

TEST(Calibration, AnExperimentsRecordPassesItsOwnCheck) {
  const json c = checked_calibration(json(measured()), kLimits);
  EXPECT_DOUBLE_EQ(c.at("noise_m").get<double>(), 0.5e-6);
  EXPECT_DOUBLE_EQ(c.at("rad_per_V").get<double>(), 31.4e-6);
  EXPECT_DOUBLE_EQ(c.at("fastest_f_hz").get<double>(), 20.0) << "its steps are the larger";
}

TEST(Calibration, ABadRecordIsRefusedNamingTheKey) {
  json c = json(measured());
  c.erase("noise_m");
  EXPECT_EQ(refusal_key(c), "calibration.noise_m");
  c = json(measured());
  c["V0"] = 200.0;  // beyond the board's V_max
  EXPECT_NE(refusal_key(c), "");
  c = json(measured());
  c["rad_per_V"] = "big";
  EXPECT_EQ(refusal_key(c), "calibration.rad_per_V");
}

TEST(Calibration, TheSmallestToleranceFollowsTheNoise) {
  const double r2 = 0.062;
  EXPECT_GT(smallest_tolerance_rad(1e-6, r2), smallest_tolerance_rad(0.5e-6, r2));
  EXPECT_NEAR(smallest_tolerance_rad(1e-6, r2) / smallest_tolerance_rad(0.5e-6, r2), 2.0, 1e-9);
  EXPECT_GE(smallest_tolerance_rad(0.5e-6, r2), resolution_rad(0.5e-6, r2));
}

TEST(Calibration, AMoveTakesTheCalibrationsFastestTable) {
  const auto c = checked_calibration(measured(), kLimits);
  firmware::MoveSettings m;
  m.V0 = c.V0;
  ASSERT_TRUE(apply_calibration(c, std::nullopt, m));
  EXPECT_DOUBLE_EQ(m.f, 20.0);
  EXPECT_DOUBLE_EQ(m.rad_per_V, 31.4e-6);
  EXPECT_DOUBLE_EQ(m.noise_prior_m, 0.5e-6);
  EXPECT_NEAR(m.step_forward_rad.back(), 2 * 2e-4 * 6, 1e-12);
  firmware::MoveSettings other = m;
  EXPECT_FALSE(apply_calibration(c, 15.0, other)) << "no table at 15 Hz: the model's stays";
}

TEST(Calibration, AFileKeepsItAndAMissingOneIsNone) {
  const auto dir = testing::fresh_temp_dir("calibration");
  const std::string path = (dir / "calibration.json").string();
  EXPECT_FALSE(load_calibration(path, kLimits).has_value());
  const auto c = checked_calibration(measured(), kLimits);
  save_calibration(path, c);
  const auto back = load_calibration(path, kLimits);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(json(*back), json(c));
  std::ofstream(path) << "{ not json";
  EXPECT_THROW((void)load_calibration(path, kLimits), std::runtime_error);
}

}  // namespace
}  // namespace piezo::daemon
