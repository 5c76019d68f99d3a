// A plain run's protection (RunGuard) without loops or HAL: the sawtooth it
// passes through unchanged, and the causes it ends a run with, judged on a
// sensor that follows a rotor stepping, blocked, frozen or blind.

#include "piezo/firmware/run_guard.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "piezo/model/waveform.hpp"

namespace piezo::firmware {
namespace {

constexpr double kDt = 1e-4;
constexpr double kR2 = 0.062;

enum class Rotor { steps, blocked, frozen, blind };

/// Drives 3 s of a 10 Hz, 80 V sawtooth through the guard; the rotor gains
/// 1.4 mrad a period (following the rise) unless blocked; the sensor reads
/// at 1 kHz. Returns the guard's fault and when it came.
std::pair<StopCause, double> drive(Rotor rotor) {
  const model::Sawtooth saw(80.0, 10.0, 0.75);
  RunGuardSettings s;
  s.noise_m = 0.5e-6;
  PositionFeed feed;
  RunGuard guard(saw, s, feed);
  double t = 0.0;
  for (long tick = 0; t < 3.0; ++tick, t += kDt) {
    const double V = guard.next_voltage(t, kDt);
    EXPECT_DOUBLE_EQ(V, saw.voltage(t)) << "the guard passes the waveform through";
    const double period = std::floor(t * 10.0);
    const double theta = rotor == Rotor::blocked ? 31.4e-6 * V  // swings, no net step
                                                 : 1.4e-3 * period + 31.4e-6 * V;
    double reading = 0.07 + kR2 * theta + 0.5e-6 * std::sin(1e3 * t);
    if (rotor == Rotor::frozen && t > 1.0) reading = 0.07;
    if (rotor == Rotor::blind && t > 1.0) reading = 0.07 + 0.5e-6 * std::sin(1e3 * t);
    if (tick % 10 == 0) feed.publish(reading);
    if (guard.fault() != StopCause::none) return {guard.fault(), t};
  }
  return {guard.fault(), t};
}

TEST(RunGuard, ASteppingRotorRunsToTheEnd) {
  EXPECT_EQ(drive(Rotor::steps).first, StopCause::none);
}

TEST(RunGuard, ABlockedRotorStallsWithinAFewPeriods) {
  const auto [cause, at] = drive(Rotor::blocked);
  EXPECT_EQ(cause, StopCause::stalled);
  EXPECT_LT(at, 0.35);
}

TEST(RunGuard, AFrozenOrBlindSensorIsImplausible) {
  for (const Rotor r : {Rotor::frozen, Rotor::blind}) {
    const auto [cause, at] = drive(r);
    EXPECT_EQ(cause, StopCause::sensor_implausible);
    EXPECT_GT(at, 1.0);
    EXPECT_LT(at, 1.35);
  }
}

}  // namespace
}  // namespace piezo::firmware
