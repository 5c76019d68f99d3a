#include "piezo/hal/sim/sim_rig.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::hal::sim {
namespace {

constexpr TimeNs kMs = 1'000'000;

// The plant fed with the sawtooth's samples at 10 kHz (first-order hold)
// moves the rotor as the continuous model does, within 0.1 %: what is left
// is the sampling of the waveform's corners.
TEST(Plant, SampledSawtoothMovesTheRotorAsTheModelPredicts) {
  const model::Parameters p;
  const model::Sawtooth saw(p.drive.V0, p.drive.f, p.drive.D());
  AmplifierSettings amp;
  amp.ramp_time_s = 1e-4;
  Plant plant(p.motor, amp, 0);
  plant.set_enabled(0, true);
  for (TimeNs k = 0; k <= 10'000; ++k) {
    plant.set_input(k * 100'000, saw.voltage(static_cast<double>(k) * 1e-4) / amp.gain);
  }
  const double expected = model::final_angle(p.motor, saw, model::FrictionModel::lugre, 1.0);
  EXPECT_NEAR(plant.latest().theta, expected, 1e-3 * expected);
  EXPECT_EQ(plant.latest().t, 1'000'000'000);
}

TEST(Plant, DisabledAmplifierOutputsNothing) {
  Plant plant(model::MotorParameters{}, AmplifierSettings{}, 0);
  plant.set_input(0, 4.0);
  plant.set_input(10 * kMs, 4.0);
  EXPECT_DOUBLE_EQ(plant.latest().V_out, 0.0);
  plant.set_enabled(10 * kMs, true);
  plant.set_input(11 * kMs, 4.0);
  EXPECT_NEAR(plant.latest().V_out, 50.0, 1e-9) << "50 V/ms slew";
  plant.set_input(15 * kMs, 4.0);
  EXPECT_DOUBLE_EQ(plant.latest().V_out, 80.0);
}

TEST(Plant, OutputSlewsAndClipsAtTheRails) {
  AmplifierSettings amp;
  amp.slew_V_per_s = 10'000;  // 10 V per ms
  amp.V_out_max = 60.0;
  Plant plant(model::MotorParameters{}, amp, 0);
  plant.set_enabled(0, true);
  plant.set_input(0, 4.0);  // asks for 80 V
  plant.set_input(2 * kMs, 4.0);
  EXPECT_NEAR(plant.latest().V_out, 20.0, 1e-9);
  plant.set_input(20 * kMs, 4.0);
  EXPECT_DOUBLE_EQ(plant.latest().V_out, 60.0);
}

TEST(SimDrive, QuantisesToTheDacCodeAndRefusesOutOfRange) {
  VirtualClock clock;
  Plant plant(model::MotorParameters{}, AmplifierSettings{}, 0);
  SimDrive drive({.bits = 12, .full_scale_V = 5.0}, plant, clock);
  EXPECT_EQ(drive.write(40.0), Status::ok);  // 2 V at the DAC
  EXPECT_EQ(drive.last_code(), 1638u);       // round(2 / 5 * 4095)
  EXPECT_EQ(drive.write(100.0), Status::ok);
  EXPECT_EQ(drive.last_code(), 4095u);
  EXPECT_EQ(drive.write(101.0), Status::out_of_range);
  EXPECT_EQ(drive.write(-1.0), Status::out_of_range);
  EXPECT_DOUBLE_EQ(drive.limits().V_max, 100.0);
}

// Software writes whenever it wakes; the DAC latches on its own 100 us grid.
TEST(SimDrive, LatchesEachCodeOnTheNextTickAndTheLastWriteWins) {
  VirtualClock clock;
  SleeperScope scope(clock);
  AmplifierSettings amp;
  amp.ramp_time_s = 0.0;
  amp.slew_V_per_s = 1e12;
  Plant plant(model::MotorParameters{}, amp, 0);
  plant.set_enabled(0, true);
  SimDrive drive({.bits = 16, .full_scale_V = 5.0, .update_period_s = 100e-6}, plant, clock, 0);
  constexpr TimeNs kUs = 1000;
  clock.sleep_until(30 * kUs);
  EXPECT_EQ(drive.write(40.0), Status::ok);
  EXPECT_DOUBLE_EQ(plant.latest().V_out, 0.0) << "not latched before its tick";
  clock.sleep_until(120 * kUs);
  EXPECT_EQ(drive.write(20.0), Status::ok);
  EXPECT_EQ(plant.latest().t, 100 * kUs) << "40 V latched at the 100 us tick";
  clock.sleep_until(150 * kUs);
  EXPECT_EQ(drive.write(60.0), Status::ok);  // same tick (200 us): overwrites 20 V
  clock.sleep_until(230 * kUs);
  EXPECT_EQ(drive.write(0.0), Status::ok);
  EXPECT_EQ(plant.latest().t, 200 * kUs);
  EXPECT_NEAR(plant.latest().V_out, 40.0, 1e-3) << "held from 100 to 200 us";
  clock.sleep_until(330 * kUs);
  EXPECT_EQ(drive.write(0.0), Status::ok);
  EXPECT_EQ(plant.latest().t, 300 * kUs);
  EXPECT_NEAR(plant.latest().V_out, 60.0, 1e-3) << "the last write before the tick won";
}

class SimSensorTest : public ::testing::Test {
 protected:
  VirtualClock clock;
  SleeperScope scope{clock};
  Plant plant{model::MotorParameters{}, AmplifierSettings{}, 0};
};

TEST_F(SimSensorTest, NoiseHasTheConfiguredSpreadAndLatencyIsHonoured) {
  SimSensorSettings s;
  s.noise_m = 1e-6;
  s.quantum_m = 0.0;
  s.latency_s = 300e-6;
  SimSensor sensor(s, plant, clock, 0);
  double sum = 0, sum_sq = 0;
  constexpr int kN = 20'000;
  for (int i = 0; i < kN; ++i) {
    const DisplacementReading r = sensor.read();
    ASSERT_EQ(r.status, Status::ok);
    ASSERT_EQ(r.t_response - r.t_request, 300'000);
    sum += r.displacement_m - s.offset_m;
    sum_sq += std::pow(r.displacement_m - s.offset_m, 2);
  }
  EXPECT_NEAR(sum / kN, 0.0, 5 * 1e-6 / std::sqrt(kN));
  EXPECT_NEAR(std::sqrt(sum_sq / kN), 1e-6, 0.03e-6);
}

TEST_F(SimSensorTest, QuantisesTheReading) {
  SimSensorSettings s;
  s.noise_m = 0.3e-6;
  s.quantum_m = 1e-6;
  SimSensor sensor(s, plant, clock, 0);
  for (int i = 0; i < 100; ++i) {
    const double steps = sensor.read().displacement_m / 1e-6;
    EXPECT_NEAR(steps, std::round(steps), 1e-6);
  }
}

TEST_F(SimSensorTest, AStalledSensorTimesOutAfterTheTimeout) {
  SimSensorSettings s;
  s.stall_at_s = 0.01;
  s.stall_for_s = 0.1;
  s.timeout_s = 0.05;
  SimSensor sensor(s, plant, clock, 0);
  EXPECT_EQ(sensor.read().status, Status::ok);
  clock.sleep_until(20 * kMs);
  const DisplacementReading r = sensor.read();
  EXPECT_EQ(r.status, Status::timeout);
  EXPECT_EQ(r.t_response - r.t_request, 50 * kMs);
  clock.sleep_until(120 * kMs);
  EXPECT_EQ(sensor.read().status, Status::ok) << "the stall is over";
}

TEST_F(SimSensorTest, DropoutsAreFlaggedAtTheConfiguredRate) {
  SimSensorSettings s;
  s.dropout_probability = 0.1;
  SimSensor sensor(s, plant, clock, 0);
  int invalid = 0;
  for (int i = 0; i < 10'000; ++i) invalid += sensor.read().status == Status::invalid_reading;
  EXPECT_NEAR(invalid, 1000, 120);
}

TEST(SimLines, EstopPressesAtItsTimeAndReportsOneEdge) {
  VirtualClock clock;
  SleeperScope scope(clock);
  Plant plant(model::MotorParameters{}, AmplifierSettings{}, 0);
  SimLines lines({.estop_at_s = 0.5}, plant, clock, 0);
  EXPECT_FALSE(lines.poll_estop().pressed);
  clock.sleep_until(500 * kMs);
  const EstopState first = lines.poll_estop();
  EXPECT_TRUE(first.pressed);
  EXPECT_TRUE(first.edge_seen);
  EXPECT_FALSE(lines.poll_estop().edge_seen);
  EXPECT_EQ(lines.set_sync(true), Status::ok);
  EXPECT_EQ(lines.set_sync(false), Status::ok);
  EXPECT_EQ(lines.set_sync(true), Status::ok);
  EXPECT_EQ(lines.sync_pulses(), 2);
}

// Each axis's trigger line keeps its history: its rising edges, and when
// the latest came; an axis the rig lacks has none.
TEST(SimLines, EachAxissTriggerLineKeepsItsRisingEdges) {
  VirtualClock clock;
  SleeperScope scope(clock);
  Plant theta(model::MotorParameters{}, AmplifierSettings{}, 0);
  Plant phi(model::MotorParameters{}, AmplifierSettings{}, 0);
  SimLines lines({}, std::vector<Plant*>{&theta, &phi}, clock, 0);
  EXPECT_TRUE(lines.has_trigger(0) && lines.has_trigger(1));
  EXPECT_FALSE(lines.has_trigger(2));
  EXPECT_EQ(lines.set_trigger(2, true), Status::io_error);
  for (int pulse = 0; pulse < 3; ++pulse) {
    clock.sleep_until((10 + 10 * pulse) * kMs);
    EXPECT_EQ(lines.set_trigger(1, true), Status::ok);
    EXPECT_EQ(lines.set_trigger(1, true), Status::ok) << "held high: no new edge";
    clock.sleep_until((11 + 10 * pulse) * kMs);
    EXPECT_EQ(lines.set_trigger(1, false), Status::ok);
  }
  EXPECT_EQ(lines.trigger_edges(1), 3);
  EXPECT_EQ(lines.last_trigger_edge_ns(1), 30 * kMs);
  EXPECT_FALSE(lines.trigger_high(1));
  EXPECT_EQ(lines.trigger_edges(0), 0) << "theta's line is its own";
}

// The button held: its reset is refused until the release; a press with
// no hold is still seen once, and each run is pressed at its own time.
TEST(SimLines, AHeldButtonRefusesItsResetUntilReleased) {
  VirtualClock clock;
  SleeperScope scope(clock);
  Plant plant(model::MotorParameters{}, AmplifierSettings{}, 0);
  SimLines held({.estop_at_s = 0.5, .estop_hold_s = 1.0}, plant, clock, 0);
  SimLines tapped({.estop_at_s = 0.5}, plant, clock, 0);
  EXPECT_TRUE(held.reset_estop());
  clock.sleep_until(600 * kMs);
  EXPECT_TRUE(held.poll_estop().edge_seen);
  const EstopState seen = tapped.poll_estop();
  EXPECT_TRUE(seen.pressed && seen.edge_seen);
  EXPECT_FALSE(tapped.poll_estop().pressed);
  EXPECT_TRUE(tapped.reset_estop());
  clock.sleep_until(1400 * kMs);
  EXPECT_TRUE(held.poll_estop().pressed);
  EXPECT_FALSE(held.reset_estop());
  clock.sleep_until(1500 * kMs);
  EXPECT_FALSE(held.poll_estop().pressed);
  EXPECT_TRUE(held.reset_estop());
  // The next run, from its own origin.
  held.set_time_origin(2000 * kMs);
  clock.sleep_until(2400 * kMs);
  EXPECT_FALSE(held.poll_estop().pressed);
  clock.sleep_until(2500 * kMs);
  EXPECT_TRUE(held.poll_estop().edge_seen);
  EXPECT_FALSE(held.reset_estop());
}

// The rig's parts share one plant: what the drive writes reaches the
// amplifier only once the lines enable it, and the sensor sees the rotor move.
TEST(SimRig, DriveLinesAndSensorShareOnePlant) {
  VirtualClock clock;
  SleeperScope scope(clock);
  SimRigSettings settings;
  settings.dac.update_period_s = 1e-4;
  settings.amplifier.ramp_time_s = 1e-4;
  settings.sensor.noise_m = 0.0;
  settings.sensor.quantum_m = 0.0;
  settings.sensor.latency_s = 0.0;
  SimRig rig(settings, clock, 0);
  const double d0 = rig.sensor().read().displacement_m;
  const model::Sawtooth saw(80.0, 10.0, 0.75);
  for (TimeNs k = 0; k < 2000; ++k) {  // 0.2 s at 10 kHz, the first 0.1 s disabled
    if (k == 1000) {
      ASSERT_EQ(rig.lines().set_amplifier_enable(true), Status::ok);
    }
    clock.sleep_until(k * 100'000);
    ASSERT_EQ(rig.drive().write(saw.voltage(static_cast<double>(k) * 1e-4)), Status::ok);
    if (k == 999) {
      EXPECT_DOUBLE_EQ(rig.plant().latest().V_out, 0.0) << "disabled: no output";
      EXPECT_DOUBLE_EQ(rig.sensor().read().displacement_m, d0);
    }
  }
  EXPECT_TRUE(rig.plant().enabled());
  EXPECT_GT(rig.plant().latest().theta, 1e-4) << "one period of the sawtooth moved the rotor";
  EXPECT_GT(rig.sensor().read().displacement_m, d0) << "and the sensor saw it";
}

}  // namespace
}  // namespace piezo::hal::sim
