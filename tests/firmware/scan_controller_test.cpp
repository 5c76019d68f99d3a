// The scan controller on its own, against the test plant of stick-slip
// kinematics (kinematic_plant.hpp) at 10 kHz with a 1 kHz sensor: its
// velocity over the span is measured on the plant's own rotor, its
// pulses counted on a line, and the velocity branch checked both ways.

#include "piezo/firmware/scan_controller.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <tuple>
#include <vector>

#include "kinematic_plant.hpp"

namespace piezo::firmware {
namespace {

/// A trigger line that keeps its rising edges' times.
class EdgeLine final : public hal::DigitalLines {
 public:
  hal::Status set_amplifier_enable(bool) override { return hal::Status::ok; }
  hal::Status set_sync(bool) override { return hal::Status::ok; }
  hal::EstopState poll_estop() override { return {}; }
  bool has_trigger(std::size_t axis) const override { return axis == 0; }
  hal::Status set_trigger(std::size_t, bool high) override {
    if (high && !high_) edges.push_back(t);
    high_ = high;
    return hal::Status::ok;
  }
  std::vector<double> edges;
  double t = 0.0;

 private:
  bool high_ = false;
};

/// The test plant's branch: it sticks on the slow edge below 2000 V/s and
/// slips on the fast one, so a step is the stroke at that amplitude.
VelocityBranch plant_branch(const TestPlant& plant, double V0) {
  VelocityBranch b;
  StepModel::Table steps{};
  for (std::size_t i = 0; i < steps.size(); ++i)
    steps[i] = plant.stick_rad_per_V * V0 * kStepFractions[i];
  for (const double f : {8.0, 12.0, 16.0}) b.add(f, steps, true);
  return b;
}

ScanSettings scan(double from, double to, double v, const TestPlant& plant) {
  ScanSettings s;
  s.from_rad = from;
  s.to_rad = to;
  s.velocity_rad_per_s = v;
  s.acceleration_s = 0.3;
  s.deceleration_s = 0.2;
  s.zero_displacement_m = kZero;
  s.r2_m = kR2;
  s.V0 = 80.0;
  s.D = 0.75;
  s.branch = plant_branch(plant, s.V0);
  const double dir = to >= from ? 1.0 : -1.0;
  s.approach.target_rad = from - dir * (v * s.acceleration_s + 0.01);
  s.approach.tolerance_rad = 2e-4;
  s.approach.zero_displacement_m = kZero;
  s.approach.r2_m = kR2;
  s.approach.approach = dir > 0 ? Approach::forward : Approach::reverse;
  return s;
}

struct Scanned {
  std::vector<TriggerPulse> pulses;
  std::vector<double> edges;
  double t_a = NAN, t_b = NAN;  ///< when the plant's rotor crossed A and B
  double t_end = 0.0, V_end = 0.0;
};

Scanned run(ScanController& c, PositionFeed& feed, TestPlant& plant, EdgeLine& line,
            double timeout_s = 60.0) {
  Scanned out;
  const ScanSettings& s = c.settings();
  const double dir = s.to_rad >= s.from_rad ? 1.0 : -1.0;
  double t = 0.0;
  for (long tick = 0; t < timeout_s; ++tick, t += kDt) {
    line.t = t;
    if (tick % kTicksPerReading == 0) {
      feed.publish(plant.read(), static_cast<std::int64_t>(t * 1e9));
    }
    plant.drive(c.next_voltage(t, kDt));
    if (c.stage() != ScanStage::approach) {
      if (std::isnan(out.t_a) && dir * (plant.theta - s.from_rad) >= 0) out.t_a = t;
      if (std::isnan(out.t_b) && dir * (plant.theta - s.to_rad) >= 0) out.t_b = t;
    }
    TriggerPulse p;
    while (c.pulses().try_pop(p)) out.pulses.push_back(p);
    if (c.finished() || c.fault() != StopCause::none) break;
  }
  out.edges = line.edges;
  out.t_end = t;
  out.V_end = plant.V;
  return out;
}

CompareSettings every(double start, double step, std::uint32_t pulses, int direction) {
  CompareSettings c;
  c.start_rad = start;
  c.step_rad = step;
  c.pulses = pulses;
  c.width_s = 5e-4;
  c.direction = direction;
  return c;
}

TEST(VelocityBranch, MapsAVelocityToTheDriveThatGivesItAndBack) {
  const TestPlant plant;
  const VelocityBranch b = plant_branch(plant, 80.0);
  const double full = plant.stick_rad_per_V * 80.0;
  EXPECT_DOUBLE_EQ(b.top(), 16.0 * full);
  EXPECT_DOUBLE_EQ(b.base_rate(), 8.0 * 0.5 * full);
  for (const double v : {0.011, 0.02, 0.025, 0.03, 0.039}) {
    const VelocityBranch::Drive d = b.drive_for(v);
    EXPECT_NEAR(b.velocity(d), v, 1e-12 + 1e-9 * v) << v;
    EXPECT_GE(d.f_hz, 8.0);
    EXPECT_LE(d.f_hz, 16.0);
  }
  EXPECT_DOUBLE_EQ(b.drive_for(0.0).fraction, 0.0) << "nothing wanted: no step";
}

TEST(VelocityBranch, EndsAtThePeak) {
  VelocityBranch b;
  StepModel::Table small{}, large{};
  small.fill(1e-4);
  large.fill(2e-4);
  b.add(10.0, large, true);  // 2 mrad/s
  b.add(20.0, large, true);  // 4 mrad/s
  b.add(40.0, small, true);  // 4 mrad/s: no faster, past the peak
  b.add(80.0, large, true);  // after the peak: not on the rising branch
  EXPECT_DOUBLE_EQ(b.top(), 4e-3);
  b.add(5.0, large, false);
  EXPECT_DOUBLE_EQ(b.base_rate(), 2e-3) << "an unreliable point is no point";
}

TEST(ScanController, TheSpanIsAtItsVelocityAndEachPositionFiresOnce) {
  for (const auto& [from, to, v] : {std::tuple{0.01, 0.05, 0.02}, std::tuple{0.0, -0.03, 0.012},
                                    std::tuple{0.0, 0.06, 0.035}}) {
    TestPlant plant;
    PositionFeed feed;
    EdgeLine line;
    const double dir = to >= from ? 1.0 : -1.0;
    ScanSettings s = scan(from, to, v, plant);
    const double step = 0.002;
    const auto pulses = static_cast<std::uint32_t>(std::floor(std::abs(to - from) / step)) + 1;
    s.triggers = true;
    s.compare = every(from, step, pulses, static_cast<int>(dir));
    s.lines = &line;
    ScanController c(s, feed);
    const Scanned r = run(c, feed, plant, line);
    ASSERT_EQ(c.stage(), ScanStage::done) << from << ".." << to << ": " << to_string(c.fault());
    EXPECT_EQ(r.V_end, 0.0) << "ends on a period's 0 V";
    // The rotor's own velocity over the span, and what the scan measured.
    const double rotor_v = std::abs(to - from) / (r.t_b - r.t_a);
    EXPECT_NEAR(rotor_v, v, 0.05 * v) << from << ".." << to;
    ASSERT_TRUE(c.span_measured());
    EXPECT_NEAR(c.measured().velocity_rad_per_s, v, 0.05 * v);
    EXPECT_GT(c.measured().periods, 5u);
    EXPECT_LT(c.measured().ripple_10_rad_per_s, 0.25 * v);
    // floor((B - A) / STEP) + 1 pulses, k = 0.. once each, one edge each.
    ASSERT_EQ(r.pulses.size(), pulses);
    EXPECT_EQ(r.edges.size(), pulses);
    EXPECT_EQ(c.pulses_fired(), pulses);
    const double reading_travel = v / 1000.0;
    for (std::uint32_t k = 0; k < pulses; ++k) {
      const TriggerPulse& p = r.pulses[k];
      EXPECT_EQ(p.k, k);
      EXPECT_DOUBLE_EQ(r.edges[k], p.edge_s);
      const double past = dir * (p.angle_rad - p.position_rad);
      EXPECT_GE(past, 0.0) << k;
      // The filtered angle moves by at most a few readings' travel in one
      // reading (its slip-back averaged) plus the noise of its mean.
      EXPECT_LE(past, 3 * reading_travel + 3 * plant.noise_m / kR2) << k;
    }
  }
}

TEST(ScanController, ARotorThatStopsFollowingStopsTheScanStalled) {
  TestPlant plant;
  PositionFeed feed;
  EdgeLine line;
  ScanSettings s = scan(0.01, 0.05, 0.02, plant);
  ScanController c(s, feed);
  // The rotor blocks once the cruise has begun.
  double t = 0.0;
  for (long tick = 0; t < 30.0; ++tick, t += kDt) {
    if (tick % kTicksPerReading == 0)
      feed.publish(plant.read(), static_cast<std::int64_t>(t * 1e9));
    plant.blocked = c.stage() == ScanStage::span;
    plant.drive(c.next_voltage(t, kDt));
    if (c.fault() != StopCause::none || c.finished()) break;
  }
  EXPECT_EQ(c.fault(), StopCause::stalled);
  EXPECT_EQ(c.stage(), ScanStage::failed);
}

TEST(ScanController, ARotorFarAheadOfItsReferenceStopsTheScanImplausible) {
  TestPlant plant;
  PositionFeed feed;
  ScanSettings s = scan(0.01, 0.05, 0.02, plant);
  ScanController c(s, feed);
  // Once the span has begun, something else turns the rotor on (a hand, a
  // cable), five times as fast as the scan: no step the scan leaves out
  // holds it back.
  double t = 0.0;
  for (long tick = 0; t < 30.0; ++tick, t += kDt) {
    if (tick % kTicksPerReading == 0)
      feed.publish(plant.read(), static_cast<std::int64_t>(t * 1e9));
    if (c.stage() == ScanStage::span) plant.theta += 5 * 0.02 * kDt;
    plant.drive(c.next_voltage(t, kDt));
    if (c.fault() != StopCause::none || c.finished()) break;
  }
  EXPECT_EQ(c.fault(), StopCause::sensor_implausible);
  EXPECT_EQ(c.stage(), ScanStage::failed);
}

}  // namespace
}  // namespace piezo::firmware
