// The firmware's loops against the simulated rig on the virtual clock:
// whole runs, far faster than real time, each outcome checked in the log.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "../support/run_command.hpp"
#include "h5_file.hpp"
#include "piezo/firmware/samples.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/model/sampled_drive.hpp"
#include "piezo/model/simulate.hpp"
#include "rig.hpp"
#include "run_config.hpp"
#include "run_log.hpp"
#include "run_session.hpp"

namespace piezo::host {
namespace {

struct Outcome {
  RunSummary summary;
  bool amplifier_enabled_at_end = true;  ///< the simulated amplifier, read after the run
  double amplifier_V_at_end = -1.0;
  std::vector<double> drive_t, drive_V, drive_phase, sensor_t, theta;
};

/// With `stop_at_s`, the host is asked to stop once the run has reached that
/// time (as a user pressing Ctrl-C mid-run), whatever the set-up took.
Outcome run_virtual(std::vector<std::string> sets, double stop_at_s = -1.0,
                    const std::string& tag = "hil") {
  sets.push_back("run.clock=virtual");
  const config::RunConfig config =
      config::load_run_config(PIEZO_SOURCE_DIR "/configs/sim.toml", sets);
  config::Rig rig = config::build_rig(config);
  const auto dir = testing::fresh_temp_dir(tag);
  const std::string path = (dir / "run.h5").string();
  RunLog log = RunLog::create(path, {{"config", config.text}});
  std::atomic<bool> stop{false};
  const auto on_status = [&stop, stop_at_s](const LiveStatus& status) {
    if (stop_at_s >= 0.0 && status.t_s >= stop_at_s) stop.store(true);
  };
  Outcome out;
  // The device side: the simulated amplifier the drive and lines act on,
  // kept here while the rig goes to the in-process piezod.
  const std::shared_ptr<const hal::sim::SimRig> device = rig.sim;
  out.summary = execute_run(config, std::move(rig), log, stop, on_status);
  out.amplifier_enabled_at_end = device->plant().enabled();
  out.amplifier_V_at_end = device->plant().latest().V_out;
  log.close(out.summary.status());
  const H5File file = H5File::open(path);
  out.drive_t = file.read("/drive/t");
  out.drive_V = file.read("/drive/V");
  out.drive_phase = file.read("/drive/phase");
  out.sensor_t = file.read("/sensor/t");
  out.theta = file.read("/sensor/theta");
  return out;
}

TEST(SimRun, AFullRunMatchesTheModel) {
  const Outcome o = run_virtual({});
  EXPECT_EQ(o.summary.status(), "completed");
  // 4.8 s at 10 kHz and 1 kHz, nothing lost, nothing late on the virtual clock.
  EXPECT_GE(o.summary.drive.samples, 48'000u);
  EXPECT_GE(o.summary.sensor.samples, 4'800u);
  EXPECT_EQ(o.summary.drive.dropped + o.summary.sensor.dropped, 0u);
  EXPECT_EQ(o.summary.drive.overruns, 0u);
  EXPECT_EQ(o.drive_t.size(), o.summary.drive.samples + 1);  // + the final "stopped" record
  EXPECT_EQ(o.sensor_t.size(), o.summary.sensor.samples);
  EXPECT_DOUBLE_EQ(o.drive_t.front(), 0.0);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
  for (std::size_t i = 1; i < o.drive_V.size(); ++i) {
    ASSERT_LE(std::abs(o.drive_V[i] - o.drive_V[i - 1]), 20'000 * 1e-4 + 1e-9)
        << "slew limit per step, at t = " << o.drive_t[i];
    ASSERT_LE(o.drive_V[i], 80.0);
  }

  // The measured angle against the model, at the sensor's sample times.
  const model::Parameters p;
  std::vector<double> times, measured;
  for (std::size_t i = 0; i < o.sensor_t.size(); ++i) {
    if (o.sensor_t[i] <= 4.8 && std::isfinite(o.theta[i])) {
      times.push_back(o.sensor_t[i]);
      measured.push_back(o.theta[i]);
    }
  }
  auto rms_against = [&](const model::Excitation& drive) {
    const auto theta = model::simulate(p.motor, drive, model::FrictionModel::lugre, times).theta;
    double sum_sq = 0.0;
    for (std::size_t i = 0; i < times.size(); ++i) sum_sq += std::pow(measured[i] - theta[i], 2);
    return std::sqrt(sum_sq / static_cast<double>(times.size()));
  };
  // Replaying the logged drive, the model matches within the sensor noise
  // (0.5 um at r2 = 62 mm: 8.1 urad, plus 0.1 um quantisation).
  std::vector<double> t_logged(o.drive_t.begin(), o.drive_t.end() - 1);
  std::vector<double> V_logged(o.drive_V.begin(), o.drive_V.end() - 1);
  const double rms_replay = rms_against(model::SampledDrive(t_logged, V_logged, 1e-4));
  EXPECT_LT(rms_replay, 2 * 8.1e-6) << "replayed drive: rms " << rms_replay << " rad";
  // Against the ideal sawtooth (`piezo simulate`), the 10 kHz sampling of the
  // waveform's corners and the DAC's steps add a slow drift: 0.07 % of the
  // travel after 4.8 s, about 40 urad rms.
  const model::Sawtooth saw(p.drive.V0, p.drive.f, p.drive.D());
  const double rms_ideal = rms_against(saw);
  EXPECT_LT(rms_ideal, 60e-6) << "ideal sawtooth: rms " << rms_ideal << " rad";
  EXPECT_NEAR(o.summary.theta_end_rad,
              model::final_angle(p.motor, saw, model::FrictionModel::lugre, 4.8),
              2e-3 * o.summary.theta_end_rad);
}

// A plant that differs from the model: the open-loop prediction drifts
// away, the corrected observer stays within the sensor noise.
TEST(SimRun, TheObserverTracksAMismatchedPlant) {
  const Outcome o = run_virtual({"plant.mu=0.12", "plant.sigma0=2000", "run.duration_s=2"});
  ASSERT_TRUE(o.summary.observer.has_value());
  const ObserverSummary& obs = *o.summary.observer;
  EXPECT_GE(obs.samples, 2000u);
  EXPECT_LT(obs.residual_rms_rad, 2 * 8.1e-6);
  EXPECT_GT(obs.open_loop_rms_rad, 20 * obs.residual_rms_rad)
      << "open loop " << obs.open_loop_rms_rad << ", corrected " << obs.residual_rms_rad;
}

TEST(SimRun, EveryEndLeavesTheSimulatedAmplifierDisabled) {
  for (const auto& end : {"lines.estop_at_s=0.3", "sensor.stall_at_s=0.3", "run.duration_s=0.3"}) {
    const Outcome o = run_virtual({end, "run.duration_s=1"});
    EXPECT_FALSE(o.amplifier_enabled_at_end) << end;
    EXPECT_EQ(o.summary.output_state(), "confirmed") << end;
    EXPECT_NEAR(o.amplifier_V_at_end, 0.0, 1.0) << end << ": disabled, slewing down";
  }
}

// Slow set-up (a Modbus connection, a log on a slow disk, mlockall) between
// building the rig and starting: the time origin is fixed after it, so the
// first cycles are not late and the sensor is not taken for stale.
TEST(SimRun, SlowSetUpBeforeTheStartIsNoSensorFault) {
  const config::RunConfig config =
      config::load_run_config(PIEZO_SOURCE_DIR "/configs/sim.toml",
                              {"run.duration_s=0.3", "run.lock_memory=false", "run.priority=0"});
  config::Rig rig = config::build_rig(config);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const auto dir = testing::fresh_temp_dir("hil-slow-setup");
  RunLog log = RunLog::create((dir / "run.h5").string(), {{"config", config.text}});
  const std::atomic<bool> never{false};
  const RunSummary s = execute_run(config, std::move(rig), log, never, {});
  EXPECT_EQ(s.cause, firmware::StopCause::completed);
}

TEST(SimRun, EstopDisablesWithinOneDrivePeriod) {
  const Outcome o = run_virtual({"lines.estop_at_s=1.0"});
  EXPECT_EQ(o.summary.cause, firmware::StopCause::estop);
  EXPECT_EQ(o.summary.status(), "failed");
  EXPECT_EQ(o.drive_phase.back(), static_cast<double>(firmware::DrivePhase::stopped));
  EXPECT_NEAR(o.drive_t.back(), 1.0, 1e-4 + 1e-9);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
}

TEST(SimRun, SensorStallRampsDownAndStops) {
  const Outcome o = run_virtual(
      {"sensor.stall_at_s=1.0", "safety.sensor_stale_s=0.1", "safety.ramp_down_V_per_s=1000"});
  EXPECT_EQ(o.summary.cause, firmware::StopCause::sensor_fault);
  EXPECT_GT(o.summary.sensor.errors, 0u);
  // The ramp starts once no good reading came for 0.1 s and lasts at most 80 ms.
  const auto ramp_start = std::find(o.drive_phase.begin(), o.drive_phase.end(),
                                    static_cast<double>(firmware::DrivePhase::ramping_down));
  ASSERT_NE(ramp_start, o.drive_phase.end());
  const double t_ramp = o.drive_t[static_cast<std::size_t>(ramp_start - o.drive_phase.begin())];
  EXPECT_NEAR(t_ramp, 1.1, 2e-3);
  EXPECT_LE(o.drive_t.back() - t_ramp, 0.08 + 1e-3);
  for (std::size_t i = 1; i < o.drive_V.size(); ++i) {
    if (o.drive_t[i] > t_ramp) {
      ASSERT_LE(o.drive_V[i - 1] - o.drive_V[i], 1000.0 * 1e-4 + 1e-9) << "ramp faster than set";
    }
  }
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
}

TEST(SimRun, DropoutsAreCountedAndTheRunGoesOn) {
  const Outcome o = run_virtual({"sensor.dropout_probability=0.02", "run.duration_s=1.0"});
  EXPECT_EQ(o.summary.status(), "completed");
  EXPECT_GT(o.summary.sensor.errors, 5u);
  EXPECT_EQ(std::count_if(o.theta.begin(), o.theta.end(), [](double v) { return std::isnan(v); }),
            static_cast<long>(o.summary.sensor.errors));
}

TEST(SimRun, AStopRequestRampsDownAndEndsInterrupted) {
  const Outcome o = run_virtual({"run.duration_s=10000"}, 0.2, "hil-stop");
  EXPECT_EQ(o.summary.cause, firmware::StopCause::interrupted);
  EXPECT_EQ(o.summary.status(), "interrupted");
  ASSERT_FALSE(o.drive_V.empty());
  EXPECT_GE(o.drive_t.back(), 0.2);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
  EXPECT_LT(o.drive_t.back(), 10000.0);
}

}  // namespace
}  // namespace piezo::host
