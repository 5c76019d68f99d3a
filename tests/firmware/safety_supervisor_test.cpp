#include "piezo/firmware/safety_supervisor.hpp"

#include <gtest/gtest.h>

namespace piezo::firmware {
namespace {

constexpr hal::TimeNs kT0 = 1'000'000'000;
constexpr hal::TimeNs kMs = 1'000'000;
const hal::EstopState kReleased{};

class SafetySupervisorTest : public ::testing::Test {
 protected:
  SafetySettings settings{.sensor_stale_s = 0.1, .max_sensor_errors = 5, .max_drive_errors = 3};
  SensorHealth sensor;
  SafetySupervisor supervisor{settings, sensor, kT0};
};

TEST_F(SafetySupervisorTest, RunsWhileAllIsWell) {
  sensor.report(true, kT0 + 50 * kMs);
  EXPECT_EQ(supervisor.check(kT0 + 100 * kMs, kReleased, false, false), SafetyAction::run);
  EXPECT_EQ(supervisor.cause(), StopCause::none);
}

TEST_F(SafetySupervisorTest, EstopDisablesAtOnceEvenDuringARamp) {
  EXPECT_EQ(supervisor.check(kT0, kReleased, true, false), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.check(kT0, {.pressed = false, .edge_seen = true}, false, false),
            SafetyAction::disable_now);
  EXPECT_EQ(supervisor.cause(), StopCause::estop);
}

TEST_F(SafetySupervisorTest, AStaleSensorRampsDown) {
  // No good reading since t0: fine for 100 ms, a fault after.
  EXPECT_EQ(supervisor.check(kT0 + 100 * kMs, kReleased, false, false), SafetyAction::run);
  EXPECT_EQ(supervisor.check(kT0 + 101 * kMs, kReleased, false, false), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.cause(), StopCause::sensor_fault);
}

TEST_F(SafetySupervisorTest, RepeatedSensorErrorsRampDown) {
  for (int i = 0; i < 4; ++i) sensor.report(false, kT0);
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, false, false), SafetyAction::run);
  sensor.report(false, kT0);
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, false, false), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.cause(), StopCause::sensor_fault);
}

TEST_F(SafetySupervisorTest, RepeatedDriveErrorsDisableAtOnce) {
  // A drive that does not take writes cannot ramp: the enable drops first.
  for (int i = 0; i < 2; ++i) supervisor.report_drive_write(hal::Status::timeout);
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, false, false), SafetyAction::run);
  supervisor.report_drive_write(hal::Status::timeout);
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, false, false), SafetyAction::disable_now);
  EXPECT_EQ(supervisor.cause(), StopCause::drive_fault);
}

TEST_F(SafetySupervisorTest, AFailingDriveOverridesARampUnderWay) {
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, true, false), SafetyAction::ramp_down);
  for (int i = 0; i < 3; ++i) supervisor.report_drive_write(hal::Status::timeout);
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, false, false), SafetyAction::disable_now);
  EXPECT_EQ(supervisor.cause(), StopCause::interrupted);
}

TEST_F(SafetySupervisorTest, TheFirstCauseSticks) {
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, true, false), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.check(kT0 + kMs, kReleased, false, true), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.cause(), StopCause::interrupted);
}

TEST_F(SafetySupervisorTest, TheEndOfTheRunCompletes) {
  sensor.report(true, kT0 + 10 * kMs);
  EXPECT_EQ(supervisor.check(kT0 + 20 * kMs, kReleased, false, true), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.cause(), StopCause::completed);
}

// The lease at the end of a run: the loop, late under load, meets the end
// of the duration and an expired lease in one check. A lease that lasted to
// the end means the run completed; one that ran out before it is a lost link.
TEST_F(SafetySupervisorTest, ALeaseThatLastedToTheEndIsACompletedRun) {
  RemoteControl remote;
  supervisor.set_remote(&remote);
  supervisor.set_end(kT0 + 5000 * kMs);
  sensor.report(true, kT0 + 5100 * kMs);
  remote.lease_deadline = kT0 + 5000 * kMs;  // the host's last renewal covered the end
  EXPECT_EQ(supervisor.check(kT0 + 5150 * kMs, kReleased, false, true), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.cause(), StopCause::completed);
}

TEST_F(SafetySupervisorTest, ALeaseThatRanOutBeforeTheEndIsALostLink) {
  RemoteControl remote;
  supervisor.set_remote(&remote);
  supervisor.set_end(kT0 + 5000 * kMs);
  sensor.report(true, kT0 + 5100 * kMs);
  remote.lease_deadline = kT0 + 4990 * kMs;
  EXPECT_EQ(supervisor.check(kT0 + 5150 * kMs, kReleased, false, true), SafetyAction::ramp_down);
  EXPECT_EQ(supervisor.cause(), StopCause::link_lost);
}

}  // namespace
}  // namespace piezo::firmware
