// Several axes on one board's loops: one tick writes every axis, an axis's
// own fault stops that axis alone (or every axis, when the board says so),
// a board cause stops them all. Each check looks at the simulated devices
// (the plants' amplifier outputs and rotors) beside the loops' records.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/loop_runner.hpp"
#include "piezo/hal/sim/sim_rig.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {
namespace {

constexpr std::size_t kAxes = 3;
constexpr double kDriveRateHz = 10'000.0;

/// An axis held at 0 V for the run's whole duration.
class AtZero final : public DriveProgram {
 public:
  double next_voltage(double, double) override { return 0.0; }
  [[nodiscard]] double end_voltage(double) const override { return 0.0; }
};

/// An axis held at 0 V that notes, tick by tick, whether it was told a
/// neighbour steps.
class Listener final : public DriveProgram {
 public:
  double next_voltage(double, double) override { return 0.0; }
  [[nodiscard]] double end_voltage(double) const override { return 0.0; }
  void set_neighbours_stepping(bool stepping, double t) override {
    (stepping ? told_stepping : told_quiet).push_back(t);
  }
  std::vector<double> told_stepping, told_quiet;
};

/// Three simulated axes, each driven by its own sawtooth, on the virtual
/// clock; what each axis's loops recorded, kept for the checks.
class ThreeAxes : public ::testing::Test {
 protected:
  ThreeAxes() {
    for (std::size_t i = 0; i < kAxes; ++i) {
      hal::sim::SimAxisSettings axis;
      axis.amplifier.ramp_time_s = 1e-4;
      axis.sensor.latency_s = 1e-4;
      axes.push_back(axis);
      // Different amplitudes and frequencies: the axes are not copies.
      const double k = static_cast<double>(i);
      waveforms.emplace_back(40.0 + 15.0 * k, 10.0 * (1.0 + k), 0.75);
    }
  }

  /// Runs the board for duration_s (unless something stops it first).
  void run(double duration_s, const RemoteControl* remote = nullptr) {
    rig = std::make_unique<hal::sim::SimRig>(axes, lines, clock, clock.now());
    programs.clear();
    std::vector<RunAxis> run_axes;
    for (std::size_t i = 0; i < kAxes; ++i) {
      if (listener[i] != nullptr) {
        programs.push_back(std::move(listener[i]));
        listening[i] = static_cast<Listener*>(programs.back().get());
      } else if (idle[i]) {
        programs.push_back(std::make_unique<AtZero>());
      } else {
        programs.push_back(std::make_unique<WaveformProgram>(waveforms[i]));
      }
      run_axes.push_back({rig->drive(i), rig->sensor(i), *programs.back(),
                          VoltageLimits{0.0, 80.0, 1e6}, waveforms[i].period(), safety});
    }
    LoopRunnerSettings settings;
    settings.drive = {kDriveRateHz, duration_s, fault_stops_all};
    settings.realtime = false;
    LoopRunner runner(settings, std::move(run_axes), clock, rig->lines(), remote);
    drive.assign(kAxes, {});
    sensor.assign(kAxes, {});
    t0 = runner.start([&](hal::TimeNs origin) { rig->set_time_origin(origin); });
    const auto take = [&] {
      for (std::size_t i = 0; i < kAxes; ++i) {
        runner.drain(
            i, [&](const DriveSample& s) { drive[i].push_back(s); },
            [&](const SensorSample& s) { sensor[i].push_back(s); });
      }
    };
    bool stop_sent = false;
    while (!runner.finished()) {
      take();
      if (stop_at_once.has_value() && !stop_sent &&
          clock.now() >= t0 + hal::from_seconds(stop_at_once->second)) {
        runner.request_axis_stop(stop_at_once->first, true);
        stop_sent = true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    runner.join();
    take();
    cause = runner.cause();
    for (std::size_t i = 0; i < kAxes; ++i) {
      causes.push_back(runner.cause(i));
      outcomes.push_back(runner.outcome(i));
    }
  }

  /// When axis i's drive stopped [s from the time origin].
  [[nodiscard]] double stopped_at(std::size_t i) const {
    return hal::to_seconds(drive[i].back().t - t0);
  }

  hal::sim::VirtualClock clock{1'000'000'000};
  std::vector<hal::sim::SimAxisSettings> axes;
  hal::sim::SimLinesSettings lines;
  std::vector<model::Sawtooth> waveforms;
  std::vector<bool> idle = std::vector<bool>(kAxes, false);  ///< held at 0 V
  /// A Listener in place of an axis's program; `listening` points at it
  /// in `programs` after the run.
  std::vector<std::unique_ptr<Listener>> listener = std::vector<std::unique_ptr<Listener>>(kAxes);
  std::vector<Listener*> listening = std::vector<Listener*>(kAxes, nullptr);
  /// The last run's programs, kept until the next run.
  std::vector<std::unique_ptr<DriveProgram>> programs;
  SafetySettings safety;
  bool fault_stops_all = false;
  /// An operator's stop at once of one axis, once the run's time passes
  /// the second (the test's loop looks every millisecond of real time).
  std::optional<std::pair<std::size_t, double>> stop_at_once;
  std::unique_ptr<hal::sim::SimRig> rig;
  hal::TimeNs t0 = 0;
  std::vector<std::vector<DriveSample>> drive;
  std::vector<std::vector<SensorSample>> sensor;
  StopCause cause = StopCause::none;
  std::vector<StopCause> causes;
  std::vector<OutputOutcome> outcomes;
};

TEST_F(ThreeAxes, OneTickWritesEveryAxisAndEachEndsAtZeroVolts) {
  run(0.3);
  EXPECT_EQ(cause, StopCause::completed);
  for (std::size_t i = 0; i < kAxes; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(causes[i], StopCause::completed);
    ASSERT_EQ(drive[i].size(), drive[0].size());
    for (std::size_t k = 0; k < drive[i].size(); ++k) {
      ASSERT_EQ(drive[i][k].t, drive[0][k].t) << "record " << k << ": one deadline for all";
    }
    EXPECT_EQ(drive[i].back().phase, DrivePhase::stopped);
    EXPECT_TRUE(outcomes[i].zero_confirmed);
    // The device side: each rotor moved by its own waveform, each DAC holds
    // 0 V and the board's one enable is off.
    EXPECT_GT(rig->plant(i).latest().theta, 1e-4);
    EXPECT_EQ(rig->drive(i).last_code(), 0u) << "the DAC holds 0 V";
    EXPECT_FALSE(rig->plant(i).enabled());
    EXPECT_GT(sensor[i].size(), 250u) << "1 kHz for 0.3 s";
  }
  EXPECT_NE(rig->plant(0).latest().theta, rig->plant(2).latest().theta);
}

TEST_F(ThreeAxes, AStalledSensorStopsItsOwnAxisWhileTheOthersGoOn) {
  axes[1].sensor.stall_at_s = 0.1;  // stops answering: its reads time out
  run(0.5);
  EXPECT_EQ(causes[1], StopCause::sensor_fault);
  EXPECT_EQ(causes[0], StopCause::completed);
  EXPECT_EQ(causes[2], StopCause::completed);
  EXPECT_EQ(cause, StopCause::sensor_fault) << "the run says what went wrong";
  EXPECT_LT(stopped_at(1), 0.35) << "the stale bound (0.1 s) after its last reading, ramped";
  EXPECT_GE(stopped_at(0), 0.5);
  EXPECT_GE(stopped_at(2), 0.5);
  EXPECT_EQ(drive[1].back().phase, DrivePhase::stopped);
  EXPECT_EQ(drive[1].back().V, 0.0);
  EXPECT_TRUE(outcomes[1].zero_confirmed);
  // Nothing lost: the others' records run on the grid to their end.
  for (std::size_t i : {0u, 2u}) {
    for (std::size_t k = 1; k < drive[i].size(); ++k) {
      ASSERT_EQ(drive[i][k].t - drive[i][k - 1].t, 100'000) << "axis " << i << " record " << k;
    }
  }
  for (std::size_t i = 0; i < kAxes; ++i) EXPECT_EQ(rig->drive(i).last_code(), 0u);
}

TEST_F(ThreeAxes, AStalledSensorCostsOnlyItsOwnAxisItsReadings) {
  // Each sensor is read on its own clock: a read that waits out its
  // timeout (50 ms) holds up its own axis alone. On one clock for all, the
  // others got one reading per timeout (20 a second instead of 1000).
  axes[1].sensor.stall_at_s = 0.1;
  run(0.5);
  const auto readings_per_s = [&](std::size_t i, double from_s, double to_s) {
    std::size_t n = 0;
    for (const SensorSample& s : sensor[i]) {
      const double t = hal::to_seconds(s.t_request - t0);
      if (t >= from_s && t < to_s && s.status == hal::Status::ok) ++n;
    }
    return static_cast<double>(n) / (to_s - from_s);
  };
  for (std::size_t i : {0u, 2u}) {
    SCOPED_TRACE(i);
    EXPECT_GE(readings_per_s(i, 0.15, 0.45), 0.9 * 1000.0) << "its own rate, 1000 a second";
  }
  EXPECT_LT(readings_per_s(1, 0.15, 0.45), 25.0) << "the stalled one: a reading per timeout";
}

TEST_F(ThreeAxes, WhenTheBoardSaysSoAnAxisFaultStopsEveryAxis) {
  fault_stops_all = true;
  axes[1].sensor.stall_at_s = 0.1;
  run(0.5);
  EXPECT_EQ(causes[1], StopCause::sensor_fault);
  EXPECT_EQ(causes[0], StopCause::other_axis_fault);
  EXPECT_EQ(causes[2], StopCause::other_axis_fault);
  EXPECT_EQ(cause, StopCause::sensor_fault);
  for (std::size_t i = 0; i < kAxes; ++i) {
    SCOPED_TRACE(i);
    EXPECT_LT(stopped_at(i), 0.4) << "ramped down with the faulty axis";
    EXPECT_EQ(drive[i].back().phase, DrivePhase::stopped);
    EXPECT_EQ(rig->drive(i).last_code(), 0u) << "the DAC holds 0 V";
  }
}

TEST_F(ThreeAxes, TheEstopStopsEveryAxisAtOnce) {
  lines.estop_at_s = 0.15;
  run(1.0);
  EXPECT_EQ(cause, StopCause::estop);
  for (std::size_t i = 0; i < kAxes; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(causes[i], StopCause::estop);
    EXPECT_NEAR(stopped_at(i), 0.15, 2e-4) << "within a drive period of the press";
    EXPECT_FALSE(rig->plant(i).enabled()) << "the board's enable dropped";
    EXPECT_EQ(rig->drive(i).last_code(), 0u) << "the DAC holds 0 V";
  }
}

TEST_F(ThreeAxes, AStopAtOnceTakesOneAxisToZeroVoltsWithoutARamp) {
  safety.ramp_down_V_per_s = 100.0;  // a ramp from the sawtooth's top would take 0.8 s
  stop_at_once = {{1, 0.2}};
  run(1.5);
  EXPECT_EQ(causes[1], StopCause::interrupted);
  EXPECT_EQ(causes[0], StopCause::completed);
  EXPECT_EQ(causes[2], StopCause::completed);
  const auto& stopped = drive[1];
  ASSERT_GE(stopped.size(), 2u);
  for (const DriveSample& s : stopped) EXPECT_NE(s.phase, DrivePhase::ramping_down);
  EXPECT_EQ(stopped.back().phase, DrivePhase::stopped);
  EXPECT_EQ(stopped.back().V, 0.0);
  EXPECT_LT(stopped_at(1), 1.0) << "well before the run's end";
  EXPECT_EQ(stopped.back().t - stopped[stopped.size() - 2].t, 100'000)
      << "0 V on the deadline after the last driven value";
  EXPECT_TRUE(outcomes[1].zero_confirmed);
  EXPECT_GE(stopped_at(0), 1.5) << "the others go on";
  for (std::size_t i = 0; i < kAxes; ++i) EXPECT_EQ(rig->drive(i).last_code(), 0u);
}

TEST_F(ThreeAxes, ALapsedLeaseStopsEveryAxis) {
  RemoteControl remote;
  remote.lease_deadline = clock.now() + hal::from_seconds(0.2);  // before t0 is fixed: ~0.18 s in
  run(1.0, &remote);
  EXPECT_EQ(cause, StopCause::link_lost);
  for (std::size_t i = 0; i < kAxes; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(causes[i], StopCause::link_lost);
    EXPECT_LT(stopped_at(i), 0.4);
    EXPECT_EQ(drive[i].back().phase, DrivePhase::stopped);
    EXPECT_EQ(rig->drive(i).last_code(), 0u) << "the DAC holds 0 V";
  }
}

// Crosstalk: axis 1 held at 0 V beside two driven axes. Uncoupled its rotor
// stays where it was to the last bit; coupled, its stator takes a share of
// the others' strokes, which carries its rotor along in stick and slips it
// on their fast edges: it creeps.
TEST_F(ThreeAxes, ACoupledRotorAtRestCreepsWhenItsNeighboursStep) {
  idle[1] = true;
  run(0.5);
  EXPECT_EQ(rig->plant(1).latest().theta, 0.0) << "uncoupled: untouched";
  const double alone = rig->plant(0).latest().theta;

  for (auto& axis : axes) axis.coupling = 0.05;
  causes.clear();
  outcomes.clear();
  run(0.5);
  EXPECT_EQ(cause, StopCause::completed);
  const double crept = rig->plant(1).latest().theta;
  EXPECT_GT(std::abs(crept), 1e-6) << "coupled: the neighbours' steps moved it";
  EXPECT_LT(std::abs(crept), std::abs(alone)) << "less than a driven axis travels";
  EXPECT_GT(std::abs(sensor[1].back().displacement_m - sensor[1].front().displacement_m), 1e-8)
      << "and its sensor saw it";
}

// Every tick, each axis is told whether another steps: a sawtooth steps
// throughout; once both stepping axes have stopped, nothing steps.
TEST_F(ThreeAxes, EachAxisIsToldWhileAnotherSteps) {
  listener[1] = std::make_unique<Listener>();
  run(0.3);
  const Listener& heard = *listening[1];
  ASSERT_GT(heard.told_stepping.size(), 2000u) << "told on every tick the others drove";
  EXPECT_TRUE(heard.told_quiet.empty()) << "the two sawtooths stepped to the end";
  // Two listeners and one sawtooth: each listener hears it; it hears none.
  listener[0] = std::make_unique<Listener>();
  listener[1] = std::make_unique<Listener>();
  causes.clear();
  outcomes.clear();
  run(0.3);
  EXPECT_TRUE(listening[0]->told_quiet.empty());
  EXPECT_GT(listening[0]->told_stepping.size(), 2000u);
}

}  // namespace
}  // namespace piezo::firmware
