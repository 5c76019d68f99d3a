// The move controller on its own, without loops, threads or HAL: a test
// plant of stick-slip kinematics (kinematic_plant.hpp) seen by a noisy
// sensor at 1 kHz, driven at 10 kHz. What is checked is
// the plant's own rotor, not only what the controller believes.

#include "piezo/firmware/move_controller.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "kinematic_plant.hpp"
#include "piezo/firmware/position_feed.hpp"

namespace piezo::firmware {
namespace {

struct Outcome {
  MoveState state;
  StopCause fault;
  double t_end;
  double V_end;
};

/// Runs the controller against the plant until it finishes, faults or
/// `timeout_s` passes.
Outcome run(MoveController& m, PositionFeed& feed, TestPlant& plant, double timeout_s = 30.0) {
  double t = 0.0;
  for (long tick = 0; t < timeout_s; ++tick, t += kDt) {
    if (tick % kTicksPerReading == 0) feed.publish(plant.read());
    plant.drive(m.next_voltage(t, kDt));
    if (m.finished() || m.fault() != StopCause::none) break;
  }
  return {m.state(), m.fault(), t, plant.V};
}

MoveSettings settings(double target_rad) {
  MoveSettings s;
  s.target_rad = target_rad;
  s.zero_displacement_m = kZero;
  s.r2_m = kR2;
  return s;
}

TEST(MoveController, ComesOnTargetBothWaysAndTheRotorIsThere) {
  for (const double target : {0.02, -0.013, 0.0004, -0.00007}) {
    TestPlant plant;
    PositionFeed feed;
    MoveController m(settings(target), feed);
    const Outcome o = run(m, feed, plant);
    ASSERT_EQ(o.state, MoveState::on_target) << target << ": ended " << to_string(o.state);
    EXPECT_GT(o.t_end, 0.1) << target << ": noise at rest, steps and the settle take time";
    EXPECT_EQ(o.V_end, 0.0) << target << ": on target at 0 V";
    // The settle's mean is within the tolerance; the rotor itself within
    // that and what the noise leaves in the mean.
    EXPECT_NEAR(m.position_rad(), target, m.settings().tolerance_rad) << target;
    EXPECT_NEAR(plant.theta, target, 1.5 * m.settings().tolerance_rad) << target;
    EXPECT_GT(m.noise_m(), 0.2e-6) << "measured at rest before the first step";
    EXPECT_LT(m.noise_m(), 1.0e-6);
  }
}

TEST(MoveController, LearnsAPlantThatStepsFarLessThanPredicted) {
  TestPlant plant;
  plant.stick_rad_per_V = 8e-6;  // a weaker piezo: a quarter of the model's stroke
  PositionFeed feed;
  MoveController m(settings(0.01), feed);
  const Outcome o = run(m, feed, plant);
  ASSERT_EQ(o.state, MoveState::on_target) << to_string(o.state);
  EXPECT_NEAR(plant.theta, 0.01, 1.5 * m.settings().tolerance_rad);
  EXPECT_GT(m.steps(), 10u) << "many small steps";
}

TEST(MoveController, AMotorThatSwingsButNeverStepsStopsStalled) {
  TestPlant plant;
  plant.never_slips = true;
  PositionFeed feed;
  MoveController m(settings(0.01), feed);
  const Outcome o = run(m, feed, plant);
  EXPECT_EQ(o.fault, StopCause::stalled) << to_string(o.state);
  EXPECT_EQ(o.state, MoveState::stalled);
  EXPECT_NEAR(plant.theta, 0.0, 1e-3) << "no net step";
  EXPECT_LE(m.steps(), 2u * kMaxStallSteps) << "given up after a few steps";
}

TEST(MoveController, AReadingThatNeverSwingsWhileTheStatorDoesIsImplausible) {
  TestPlant plant;
  plant.blocked = true;  // the sensor sees no rotor move at all, not even in stick
  PositionFeed feed;
  MoveController m(settings(0.01), feed);
  const Outcome o = run(m, feed, plant);
  EXPECT_EQ(o.fault, StopCause::sensor_implausible) << to_string(o.state);
  EXPECT_EQ(plant.theta, 0.0);
}

TEST(MoveController, AFrozenSensorIsImplausible) {
  TestPlant plant;
  plant.frozen = true;
  PositionFeed feed;
  MoveController m(settings(0.01), feed);
  const Outcome o = run(m, feed, plant);
  EXPECT_EQ(o.fault, StopCause::sensor_implausible) << to_string(o.state);
  EXPECT_LT(o.t_end, 5.0) << "found within a few steps";
}

TEST(MoveController, WithoutProtectionItDrivesOnUntilTheCallerStopsIt) {
  TestPlant plant;
  plant.blocked = true;
  PositionFeed feed;
  MoveSettings s = settings(0.01);
  s.protect = false;
  MoveController m(s, feed);
  const Outcome o = run(m, feed, plant, 5.0);
  EXPECT_EQ(o.fault, StopCause::none);
  EXPECT_GE(o.t_end, 5.0 - kDt) << "the run's timeout is the only end";
}

TEST(MoveController, WithoutAZeroItTakesTheMeanOfTheReadingsAtRest) {
  TestPlant plant;
  PositionFeed feed;
  MoveSettings s = settings(0.005);
  s.zero_displacement_m = std::nan("");
  MoveController m(s, feed);
  const Outcome o = run(m, feed, plant);
  ASSERT_EQ(o.state, MoveState::on_target) << to_string(o.state);
  // 16 readings of 0.5 um noise: the zero within a few tenths of a micrometre.
  EXPECT_NEAR(m.zero_displacement_m(), kZero, 0.5e-6);
  EXPECT_NEAR(plant.theta, 0.005, 1.5 * s.tolerance_rad + 0.5e-6 / kR2);
}

TEST(MoveController, AHoldKeepsTheServoOnThenSettlesAgain) {
  TestPlant plant;
  PositionFeed feed;
  MoveSettings s = settings(0.003);
  s.hold_s = 0.5;
  MoveController m(s, feed);
  const Outcome o = run(m, feed, plant);
  ASSERT_EQ(o.state, MoveState::on_target) << to_string(o.state);
  EXPECT_EQ(o.V_end, 0.0);
  EXPECT_TRUE(std::isfinite(m.hold_rms_error_rad()));
  EXPECT_LT(m.hold_rms_error_rad(), s.tolerance_rad);
  EXPECT_NEAR(plant.theta, 0.003, 1.5 * s.tolerance_rad);
}

/// A hold while a neighbour on the same frame steps: its readings shake
/// (crosstalk). Told the neighbour steps, the servo holds its output
/// instead of chasing each shake; not told, it chases them. Either way the
/// move ends on target once the shaking is over.
double held_output_swing(bool told) {
  TestPlant plant;
  PositionFeed feed;
  MoveSettings s = settings(0.003);
  s.hold_s = 1.5;
  MoveController m(s, feed);
  double t = 0.0, V_min = INFINITY, V_max = -INFINITY, shaken_from = -1.0;
  for (long tick = 0; t < 30.0; ++tick, t += kDt) {
    // 0.4 s of a neighbour's 20 Hz steps, from 0.1 s into the hold.
    const bool shaking = shaken_from >= 0.0 && t >= shaken_from && t < shaken_from + 0.4;
    if (shaken_from < 0.0 && m.state() == MoveState::holding) shaken_from = t + 0.1;
    if (told) m.set_neighbours_stepping(shaking, t);
    if (tick % kTicksPerReading == 0) {
      const double shake = shaking ? 2e-6 * std::sin(2.0 * M_PI * 20.0 * t) : 0.0;
      feed.publish(plant.read() + shake);
    }
    const double V = m.next_voltage(t, kDt);
    plant.drive(V);
    if (shaking && t > shaken_from + 0.05) {
      V_min = std::min(V_min, V);
      V_max = std::max(V_max, V);
    }
    if (m.finished() || m.fault() != StopCause::none) break;
  }
  EXPECT_EQ(m.state(), MoveState::on_target) << to_string(m.state());
  EXPECT_NEAR(plant.theta, 0.003, 1.5 * s.tolerance_rad);
  EXPECT_GT(shaken_from, 0.0) << "it held";
  return V_max - V_min;
}

TEST(MoveController, AHoldDoesNotChaseANeighboursShake) {
  EXPECT_EQ(held_output_swing(true), 0.0) << "told: the servo holds still";
  EXPECT_GT(held_output_swing(false), 0.05) << "not told: it chases the shake";
}

/// Twenty moves in a row on one rotor, to targets that alternate between
/// two angles (each move's target is behind the rotor every other time),
/// with the given approach: how each move's last change of the rotor's
/// position at rest arrived (a fine hold's release may drag the rotor back
/// by what the hold moved it: that leaves the position where it was).
std::vector<double> arrivals(Approach approach) {
  TestPlant plant;
  PositionFeed feed;
  std::vector<double> last_motions;
  for (int i = 0; i < 20; ++i) {
    MoveSettings s = settings((i % 2 == 0 ? 3e-3 : 1e-3) + 1e-5 * i);
    s.approach = approach;
    MoveController m(s, feed);
    const Outcome o = run(m, feed, plant);
    EXPECT_EQ(o.state, MoveState::on_target) << "move " << i << ": " << to_string(o.state);
    EXPECT_NEAR(plant.theta, s.target_rad, 1.5 * s.tolerance_rad) << "move " << i;
    last_motions.push_back(plant.arrival);
  }
  return last_motions;
}

TEST(MoveController, AForwardApproachArrivesFromBelowEveryTime) {
  const auto last = arrivals(Approach::forward);
  for (std::size_t i = 0; i < last.size(); ++i) {
    EXPECT_GT(last[i], 0.0) << "move " << i << ": arrived backwards";
  }
}

TEST(MoveController, AReverseApproachArrivesFromAboveEveryTime) {
  const auto last = arrivals(Approach::reverse);
  for (std::size_t i = 0; i < last.size(); ++i) {
    EXPECT_LT(last[i], 0.0) << "move " << i << ": arrived forwards";
  }
}

TEST(MoveController, EitherApproachArrivesFromWhicheverSideTheRotorIsOn) {
  // What the two tests above exclude happens without an approach side:
  // some moves down arrive backwards (a reverse fine stage), so those
  // tests measure the approach, not the plant.
  const auto last = arrivals(Approach::either);
  const auto backwards = std::count_if(last.begin(), last.end(), [](double d) { return d < 0.0; });
  EXPECT_GE(backwards, 1) << "of 20 moves, half of them down";
  EXPECT_LT(backwards, 20);
}

}  // namespace
}  // namespace piezo::firmware
