// The fine servo against a rotor that sticks to the stator (rad_per_V per
// volt while the stator moves slowly; left behind by a fast lift): the
// integral law closes in, an approach side is never backed out of, the
// range's ends are reported, and the slews are the slow and the fast one.

#include "piezo/firmware/fine_servo.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace piezo::firmware {
namespace {

constexpr FineServo::Settings kSettings{
    .rad_per_V = 30e-6, .V_max = 64.0, .slow_V_per_s = 400.0, .fast_V_per_s = 8000.0};
constexpr double kDt = 1e-4;

/// The stator's voltage and the rotor that sticks to it.
struct StickingRotor {
  double V = 0.0, theta = 0.0;
  /// Runs the servo's output for `seconds`; the rotor follows slow moves only.
  void run(FineServo& servo, double seconds) {
    for (double t = 0.0; t < seconds; t += kDt) {
      bool lift_done = false;
      const double next = servo.output(V, kDt, lift_done);
      if (!servo.lifting() && !lift_done) theta += kSettings.rad_per_V * (next - V);
      V = next;
    }
  }
};

TEST(FineServo, ClosesInOnTheTargetOneShareAReading) {
  FineServo servo(kSettings);
  StickingRotor rotor;
  const double target = 1.2e-3;  // 40 V of stick
  servo.raise_to(0.0);
  int corrections = 0;
  double last_error = target;
  for (int reading = 0; reading < 1000; ++reading) {
    rotor.run(servo, 0.005);  // a 200 Hz sensor
    // As the move controller does: readings while the output lags the set
    // point are not integrated.
    if (!servo.integrating(rotor.V)) continue;
    const double error = target - rotor.theta;
    EXPECT_LE(std::abs(error), std::abs(last_error) + 1e-12) << "never away from the target";
    last_error = error;
    servo.correct(error, 0.0);
    ++corrections;
  }
  EXPECT_NEAR(rotor.theta, target, 1e-9);
  EXPECT_NEAR(servo.set_point(), target / kSettings.rad_per_V, 1e-4);
  EXPECT_GT(corrections, 100);
}

TEST(FineServo, DoesNotIntegrateWhileTheOutputLags) {
  FineServo servo(kSettings);
  servo.raise_to(10.0);
  EXPECT_FALSE(servo.integrating(0.0));
  bool lift_done = false;
  const double V = servo.output(0.0, kDt, lift_done);
  EXPECT_DOUBLE_EQ(V, kSettings.slow_V_per_s * kDt) << "raised slowly";
  EXPECT_FALSE(lift_done);
}

TEST(FineServo, ALiftIsFastAndEndsOnceReached) {
  FineServo servo(kSettings);
  servo.lift_to(32.0);
  bool lift_done = false;
  double V = servo.output(0.0, kDt, lift_done);
  EXPECT_DOUBLE_EQ(V, kSettings.fast_V_per_s * kDt);
  int periods = 1;
  while (!lift_done) {
    V = servo.output(V, kDt, lift_done);
    ++periods;
  }
  EXPECT_EQ(periods, static_cast<int>(std::ceil(32.0 / (kSettings.fast_V_per_s * kDt))));
  EXPECT_FALSE(servo.lifting());
  EXPECT_TRUE(servo.integrating(V));
  // Then down slowly.
  servo.correct(-300e-6, 0.0);  // 10 V down at the 10 % share: 1 V
  EXPECT_DOUBLE_EQ(servo.set_point(), 31.0);
  EXPECT_DOUBLE_EQ(servo.output(V, kDt, lift_done), 32.0 - kSettings.slow_V_per_s * kDt);
}

TEST(FineServo, AnApproachSideIsNeverBackedOutOf) {
  FineServo servo(kSettings);
  servo.raise_to(20.0);
  servo.correct(-1e-3, +1.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), 20.0) << "forward only: an overshoot is not corrected";
  servo.correct(+60e-6, +1.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), 20.2);
  servo.correct(+60e-6, -1.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), 20.2) << "reverse only";
  servo.correct(-60e-6, -1.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), 20.0);
}

TEST(FineServo, TheRangesEndsAreHeldAndReported) {
  FineServo servo(kSettings);
  servo.raise_to(100.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), kSettings.V_max);
  EXPECT_TRUE(servo.at_range_end(50e-6, 25e-6)) << "more to go up, and no room";
  EXPECT_FALSE(servo.at_range_end(10e-6, 25e-6)) << "within the tolerance";
  EXPECT_FALSE(servo.at_range_end(-50e-6, 25e-6)) << "down is free";
  servo.raise_to(-5.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), 0.0);
  EXPECT_TRUE(servo.at_range_end(-50e-6, 25e-6));
  servo.correct(-1.0, 0.0);
  EXPECT_DOUBLE_EQ(servo.set_point(), 0.0);
}

}  // namespace
}  // namespace piezo::firmware
