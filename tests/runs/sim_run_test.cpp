// The firmware's loops against the simulated rig on the virtual clock:
// whole runs, far faster than real time, each outcome checked in the log.

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <iostream>
#include <thread>

#include "../support/run_command.hpp"
#include "build_paths.hpp"
#include "config/config_file.hpp"
#include "config/rig.hpp"
#include "io/h5_file.hpp"
#include "io/run_log.hpp"
#include "piezo/firmware/samples.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/model/sampled_drive.hpp"
#include "piezo/model/simulate.hpp"
#include "run/run_session.hpp"

namespace piezo::host {
namespace {

using namespace std::chrono_literals;

struct Outcome {
  RunSummary summary;
  bool amplifier_enabled_at_end = true;  ///< the simulated amplifier, read after the run
  double amplifier_V_at_end = -1.0;
  double rotor_theta_at_end = 0.0;  ///< the simulated rotor's own angle
  std::vector<double> drive_t, drive_V, drive_phase, move_state, sensor_t, theta;
};

/// The board's account of the run's one axis's move as the wire carries it (nil: none).
nlohmann::json move_of(const Outcome& o) {
  const auto& axes = o.summary.board.axes;
  return axes.size() == 1 && axes[0].move ? nlohmann::json(*axes[0].move) : nlohmann::json();
}

/// With `stop_at_s`, the host is asked to stop once the run has reached that
/// time (as a user pressing Ctrl-C mid-run), whatever the set-up took.
/// With `step_periods`, a step (`piezo step`): that many whole periods;
/// with `move`, a closed-loop move (`piezo move`).
Outcome run_virtual(std::vector<std::string> sets, double stop_at_s = -1.0,
                    const std::string& tag = "hil", std::uint64_t step_periods = 0,
                    std::optional<asked::Move> move = std::nullopt) {
  sets.push_back("run.clock=virtual");
  config::ConfigFile config =
      config::load_config_file(std::string(build_paths::source_dir) + "/configs/sim.toml", sets);
  RunAsked asked = asked::Timed{};
  if (step_periods > 0) {
    asked = asked::Periods{step_periods};
    config.host.run.duration_s = static_cast<double>(step_periods) / config.host.model.drive.f;
  }
  if (move) {
    asked = *move;
    config.host.run.duration_s = move->timeout_s;
  }
  config::Rig rig = config::build_rig(config.board);
  const auto dir = testing::fresh_temp_dir(tag);
  const std::string path = (dir / "run.h5").string();
  RunLog log = RunLog::create(path, {{"config", config.text}}, {"rotor"});
  std::atomic<bool> stop{false};
  const auto on_status = [&stop, stop_at_s](const LiveStatus& status) {
    if (stop_at_s >= 0.0 && status.t_s >= stop_at_s) stop.store(true);
  };
  Outcome out;
  // The device side: the simulated amplifier the drive and lines act on,
  // kept here while the rig goes to the in-process piezod.
  const std::shared_ptr<const hal::sim::SimRig> device = rig.sim;
  out.summary = execute_run(config, asked, std::move(rig), log, stop, on_status);
  out.amplifier_enabled_at_end = device->plant().enabled();
  out.amplifier_V_at_end = device->plant().latest().V_out;
  out.rotor_theta_at_end = device->plant().latest().theta;
  log.close(out.summary.status());
  const H5File file = H5File::open(path);
  out.drive_t = file.read("/axes/rotor/drive/t");
  out.drive_V = file.read("/axes/rotor/drive/V");
  out.drive_phase = file.read("/axes/rotor/drive/phase");
  out.move_state = file.read("/axes/rotor/drive/move_state");
  out.sensor_t = file.read("/axes/rotor/sensor/t");
  out.theta = file.read("/axes/rotor/sensor/theta");
  return out;
}

TEST(SimRun, AFullRunMatchesTheModel) {
  const Outcome o = run_virtual({});
  EXPECT_EQ(o.summary.status(), "completed");
  // 4.8 s at 10 kHz and 1 kHz, nothing lost, nothing late on the virtual clock.
  EXPECT_GE(o.summary.board.drive.cycles, 48'000u);
  EXPECT_GE(o.summary.board.sensor.cycles, 4'800u);
  EXPECT_EQ(o.summary.board.drive.dropped + o.summary.board.sensor.dropped, 0u);
  EXPECT_EQ(o.summary.board.drive.overruns, 0u);
  EXPECT_EQ(o.drive_t.size(), o.summary.board.drive.cycles + 1);  // + the final "stopped" record
  // 4.8 s is 48 whole periods: the stop is the period's 0 V at 4.8 s, no ramp.
  EXPECT_NEAR(o.drive_t.back(), 4.8, 1e-9);
  EXPECT_EQ(o.sensor_t.size(), o.summary.board.sensor.cycles);
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
    // The run's zero is its first reading, with that reading's noise: a
    // constant offset of the frame, not an error of the model's.
    double offset = 0.0;
    for (std::size_t i = 0; i < times.size(); ++i) offset += measured[i] - theta[i];
    offset /= static_cast<double>(times.size());
    double sum_sq = 0.0;
    for (std::size_t i = 0; i < times.size(); ++i) {
      sum_sq += std::pow(measured[i] - theta[i] - offset, 2);
    }
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

// The protocol's `step`: exactly N whole periods, each ending at 0 V, so
// the run ends there; the mirrored sawtooth turns the simulated rotor back.
TEST(SimRun, StepsRunWholePeriodsAndReverseTurnsTheRotorBack) {
  constexpr std::uint64_t kSteps = 5;
  const model::Parameters p;
  const double T = 1.0 / p.drive.f;
  for (const auto direction : {model::Direction::forward, model::Direction::reverse}) {
    const std::string name(model::name(direction));
    const Outcome o = run_virtual({"drive.direction=" + name}, -1.0, "hil-step", kSteps);
    EXPECT_EQ(o.summary.status(), "completed") << name;
    EXPECT_FALSE(o.amplifier_enabled_at_end) << name;
    // The last period ends at 0 V; read at the disable, one drive cycle
    // later, the amplifier's own lag (its 100 us hold) leaves under a volt.
    EXPECT_NEAR(o.amplifier_V_at_end, 0.0, 1.0) << name;
    // Driving samples cover [0, N T) at 10 kHz, and nothing is left to ramp.
    std::size_t driving = 0;
    for (std::size_t i = 0; i < o.drive_t.size(); ++i) {
      if (o.drive_phase[i] != static_cast<double>(firmware::DrivePhase::driving)) continue;
      ++driving;
      EXPECT_LT(o.drive_t[i], kSteps * T - 1e-6) << name;
    }
    EXPECT_EQ(driving, static_cast<std::size_t>(kSteps * T * 1e4 + 0.5)) << name;
    // The record at N T is the period's 0 V and the stop itself: nothing
    // ramps after the last fast edge, and no record says ramping_down.
    EXPECT_NEAR(o.drive_t.back(), kSteps * T, 1e-6) << name << ": stopped on the period's end";
    EXPECT_EQ(o.drive_V.back(), 0.0) << name;
    EXPECT_EQ(o.drive_phase.back(), static_cast<double>(firmware::DrivePhase::stopped)) << name;
    EXPECT_EQ(std::count(o.drive_phase.begin(), o.drive_phase.end(),
                         static_cast<double>(firmware::DrivePhase::ramping_down)),
              0)
        << name;
    // The device's rotor went the commanded way, as far as the model says.
    const model::Sawtooth saw(p.drive.V0, p.drive.f, model::rise_fraction(p.drive.D(), direction));
    const double expected =
        model::final_angle(p.motor, saw, model::FrictionModel::lugre, kSteps * T);
    EXPECT_EQ(std::signbit(o.rotor_theta_at_end), direction == model::Direction::reverse) << name;
    EXPECT_NEAR(o.rotor_theta_at_end, expected, 0.02 * std::abs(expected)) << name;
    // The measured travel: the last reading comes up to a sensor period
    // before the rotor's final state.
    EXPECT_NEAR(o.summary.theta_end_rad, o.rotor_theta_at_end, 0.01 * std::abs(expected))
        << name << ": sensor";
  }
}

// Closed-loop moves on a plant whose friction and piezo coefficient differ
// from the model the controller predicts with (mu +25 %, d_e -24 %, sigma0
// +21 %): every move ends on target, checked on the simulated rotor itself,
// within 3x the sensor's noise (0.5 um at r2 = 62 mm: 8.1 urad), with the
// drive at 0 V and the amplifier disabled; "on target" comes only after the
// settle time at 0 V, never while passing through.
TEST(SimRun, MovesEndOnTargetOnAMismatchedPlantBothWays) {
  const std::vector<std::string> mismatch{"plant.mu=0.125", "plant.d_e=0.42e-6",
                                          "plant.sigma0=2000", "drive.f=40"};
  constexpr double kNoise = 0.5e-6 / 0.062;
  for (const double target : {1e-4, 1e-3, 1e-2, 1e-1, -1e-4, -1e-3, -1e-2, -1e-1}) {
    asked::Move move{
        {.target_rad = target, .tolerance_rad = 15e-6, .settle_s = 0.1, .timeout_s = 30.0}};
    const Outcome o = run_virtual(mismatch, -1.0, "hil-move", 0, move);
    const nlohmann::json m = move_of(o);
    ASSERT_TRUE(m.is_object()) << target;
    EXPECT_EQ(m.at("stop_cause"), "on_target") << target;
    EXPECT_TRUE(m.at("on_target").get<bool>()) << target;
    EXPECT_EQ(o.summary.status(), "completed") << target;
    EXPECT_NEAR(o.rotor_theta_at_end, target, 3 * kNoise) << target << ": the rotor itself";
    EXPECT_FALSE(o.amplifier_enabled_at_end) << target;
    EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0) << target;
    // On target once, at the end, at 0 V, after settle_s within tolerance.
    const double on_at = m.at("on_target_at_s").get<double>();
    std::size_t first_on = o.move_state.size();
    for (std::size_t i = 0; i < o.move_state.size(); ++i) {
      if (o.move_state[i] == 5.0 && first_on == o.move_state.size()) first_on = i;
      if (first_on < o.move_state.size()) {
        ASSERT_EQ(o.move_state[i], 5.0) << target << ": left on_target at " << o.drive_t[i];
      }
      if (o.drive_t[i] > on_at - move.settle_s && o.drive_t[i] <= on_at) {
        ASSERT_EQ(o.drive_V[i], 0.0) << target << ": settling at 0 V";
      }
    }
    ASSERT_LT(first_on, o.move_state.size()) << target;
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < o.sensor_t.size(); ++i) {
      if (o.sensor_t[i] > on_at - move.settle_s && o.sensor_t[i] <= on_at &&
          std::isfinite(o.theta[i])) {
        sum += o.theta[i];
        ++n;
      }
    }
    ASSERT_GT(n, 50) << target;
    EXPECT_NEAR(sum / n, target, move.tolerance_rad) << target << ": the settle window's readings";
  }
}

// A move that cannot finish: the sensor stalls, or the e-stop is pressed.
// Either ends the move with its cause, the drive at 0 V and the amplifier
// disabled, on the simulated amplifier itself.
TEST(SimRun, AMoveIntoAStalledSensorOrAnEstopStopsAtZeroVolts) {
  asked::Move far{{.target_rad = 0.05, .tolerance_rad = 15e-6, .settle_s = 0.1, .timeout_s = 10.0}};
  for (const auto& [fault, cause] :
       {std::pair{std::string("sensor.sim.stall_at_s=0.3"), std::string("sensor_fault")},
        std::pair{std::string("lines.sim.estop_at_s=0.3"), std::string("estop")}}) {
    const Outcome o =
        run_virtual({fault, "safety.sensor_stale_s=0.05"}, -1.0, "hil-move-fault", 0, far);
    EXPECT_EQ(move_of(o).at("stop_cause"), cause) << fault;
    EXPECT_FALSE(move_of(o).at("on_target").get<bool>()) << fault;
    EXPECT_FALSE(o.amplifier_enabled_at_end) << fault;
    // The e-stop disables at once, mid-step (the simulated amplifier's last
    // sample still shows the voltage it was cut at); the stalled sensor
    // ramps the drive down first.
    if (cause == "sensor_fault") {
      EXPECT_NEAR(o.amplifier_V_at_end, 0.0, 1.0) << fault;
    }
    EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0) << fault;
    EXPECT_LT(o.drive_t.back(), 0.6) << fault;
  }
  // A target out of reach within the timeout ends as such, at 0 V.
  asked::Move unreachable{
      {.target_rad = 1.0, .tolerance_rad = 15e-6, .settle_s = 0.1, .timeout_s = 0.5}};
  const Outcome o = run_virtual({}, -1.0, "hil-move-timeout", 0, unreachable);
  EXPECT_EQ(move_of(o).at("stop_cause"), "timeout");
  EXPECT_FALSE(o.amplifier_enabled_at_end);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
  // Its position is the rotor's at 0 V, read after the stop (before, the
  // controller's last reading, from before the ramp: up to a step off).
  EXPECT_NEAR(move_of(o).at("position_rad").get<double>(), o.rotor_theta_at_end, 20e-6);
  std::cout << "timed-out move: reported " << move_of(o).at("position_rad").get<double>() * 1e3
            << " mrad, the rotor at " << o.rotor_theta_at_end * 1e3 << " mrad\n";
}

// A move's protection, seen on the simulated device: a rotor that cannot
// step (friction no drive overcomes, at any of the frequencies tried: it
// rides the stator to and fro) ends
// `stalled` once the other frequencies did no better; a sensor whose value
// froze, and one that sees a rotor that is not driven (the angle it had,
// with its noise: no swing at all while the stator swings), end
// `sensor_implausible`. Each within 1 s of drive, at 0 V with the amplifier
// disabled, the rotor no more than two steps past where the failure began
// (before, each drove to its 10 s timeout: the blind sensor's rotor ran
// 0.4 rad in the probe).
TEST(SimRun, AMoveThatCannotProgressStopsAtZeroVoltsWithItsCause) {
  asked::Move far{{.target_rad = 0.05, .tolerance_rad = 25e-6, .settle_s = 0.1, .timeout_s = 10.0}};
  const double full_step = 1.4e-3;  // the model's at 80 V, 10 Hz (configs/sim.toml)
  for (const auto& [fault, cause] :
       {std::pair{std::string("plant.mu=2,plant.F_N=0.05"), std::string("stalled")},
        std::pair{std::string("sensor.sim.freeze_at_s=0.3"), std::string("sensor_implausible")},
        std::pair{std::string("sensor.sim.blind_at_s=0.3"), std::string("sensor_implausible")}}) {
    SCOPED_TRACE(fault);
    std::vector<std::string> sets;
    for (std::size_t at = 0; at != std::string::npos;) {
      const std::size_t comma = fault.find(',', at);
      sets.push_back(fault.substr(at, comma == std::string::npos ? comma : comma - at));
      at = comma == std::string::npos ? comma : comma + 1;
    }
    const Outcome o = run_virtual(sets, -1.0, "hil-move-protect", 0, far);
    EXPECT_EQ(move_of(o).at("stop_cause"), cause);
    EXPECT_EQ(o.summary.stop_cause(), cause);
    EXPECT_FALSE(move_of(o).at("on_target").get<bool>());
    EXPECT_FALSE(o.amplifier_enabled_at_end);
    EXPECT_NEAR(o.amplifier_V_at_end, 0.0, 1.0);
    EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
    const double failed_at = fault.starts_with("plant") ? 0.0 : 0.3;
    EXPECT_LT(o.drive_t.back(), failed_at + 1.0) << "stopped within 1 s of drive";
    // Where the rotor was when the failure began: the readings up to then.
    double theta_then = 0.0;
    for (std::size_t i = 0; i < o.sensor_t.size() && o.sensor_t[i] <= failed_at; ++i) {
      if (std::isfinite(o.theta[i])) theta_then = o.theta[i];
    }
    EXPECT_LT(o.rotor_theta_at_end - theta_then, 2.0 * full_step)
        << "the rotor went on " << o.rotor_theta_at_end - theta_then << " rad";
    std::cout << fault << ": " << o.summary.stop_cause() << " at " << o.drive_t.back()
              << " s, the rotor " << (o.rotor_theta_at_end - theta_then) * 1e3
              << " mrad past where the failure began\n";
  }
}

// A rotor against an end stop (the simulated plant's, 3 mrad out) while a
// move asks for 50 mrad: `stalled` within 1 s of reaching it, at 0 V, the
// rotor at the stop (it is dragged back a little in each slip: that swing
// tells a blocked rotor from a sensor that does not see it).
TEST(SimRun, AMoveIntoAnEndStopEndsStalled) {
  asked::Move far{{.target_rad = 0.05, .tolerance_rad = 25e-6, .settle_s = 0.1, .timeout_s = 10.0}};
  const Outcome o = run_virtual({"plant.end_stop_rad=0.003"}, -1.0, "hil-move-end-stop", 0, far);
  EXPECT_EQ(move_of(o).at("stop_cause"), "stalled");
  EXPECT_FALSE(o.amplifier_enabled_at_end);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
  EXPECT_LE(o.rotor_theta_at_end, 0.003 + 1e-9);
  double reached = -1.0;
  for (std::size_t i = 0; i < o.sensor_t.size() && reached < 0.0; ++i) {
    if (std::isfinite(o.theta[i]) && o.theta[i] > 0.0029) reached = o.sensor_t[i];
  }
  ASSERT_GE(reached, 0.0) << "the rotor never came to the stop";
  EXPECT_LT(o.drive_t.back(), reached + 1.0) << "stopped within 1 s of reaching the stop";
  std::cout << "end stop at 3 mrad reached at " << reached << " s; stalled at " << o.drive_t.back()
            << " s\n";
}

// With [safety] protect_runs a plain run is watched as a move's steps are,
// period by period: a sensor that stops seeing the rotor ends it
// `sensor_implausible`, a rotor that cannot step `stalled`, each within
// 1 s of drive at 0 V with the amplifier disabled, the rotor no more than
// two steps past the failure; an ordinary run and steps complete.
TEST(SimRun, APlainRunWithProtectionStopsOnABlindSensorOrAStuckRotor) {
  const std::string on = "safety.protect_runs=true";
  EXPECT_EQ(run_virtual({on, "run.duration_s=1"}).summary.stop_cause(), "completed");
  EXPECT_EQ(run_virtual({on, "drive.direction=reverse", "run.duration_s=1"}).summary.stop_cause(),
            "completed");
  EXPECT_EQ(run_virtual({on}, -1.0, "hil-guard-steps", 5).summary.stop_cause(), "completed");
  const double full_step = 1.4e-3;
  struct Case {
    std::vector<std::string> sets;
    const char* cause;
    double failed_at;
  };
  for (const Case& c :
       {Case{{on, "run.duration_s=5", "sensor.sim.blind_at_s=0.5"}, "sensor_implausible", 0.5},
        Case{{on, "run.duration_s=5", "sensor.sim.freeze_at_s=0.5"}, "sensor_implausible", 0.5},
        Case{{on, "run.duration_s=5", "plant.mu=2", "plant.F_N=0.05"}, "stalled", 0.0}}) {
    SCOPED_TRACE(c.sets.back());
    const Outcome o = run_virtual(c.sets, -1.0, "hil-guard");
    EXPECT_EQ(o.summary.stop_cause(), c.cause);
    EXPECT_EQ(o.summary.status(), "failed");
    EXPECT_FALSE(o.amplifier_enabled_at_end);
    EXPECT_NEAR(o.amplifier_V_at_end, 0.0, 1.0);
    EXPECT_LT(o.drive_t.back(), c.failed_at + 1.0) << "stopped within 1 s of drive";
    double theta_then = 0.0;
    for (std::size_t i = 0; i < o.sensor_t.size() && o.sensor_t[i] <= c.failed_at; ++i) {
      if (std::isfinite(o.theta[i])) theta_then = o.theta[i];
    }
    EXPECT_LT(o.rotor_theta_at_end - theta_then, 2.0 * full_step);
    std::cout << c.sets.back() << ": " << o.summary.stop_cause() << " at " << o.drive_t.back()
              << " s, the rotor " << (o.rotor_theta_at_end - theta_then) * 1e3
              << " mrad past where the failure began\n";
  }
}

// With five times the default sensor noise (2.5 um at 1 kHz: 14 urad for
// an 8-reading mean against a 25 urad tolerance) a move still comes on
// target: settling averages as many readings as the noise measured at rest
// asks for and judges the mean with its confidence interval (before, the
// 8-reading mean left the window now and then, the move started again and
// was never on target: it timed out). The rotor, read from the simulated
// device, is where the move says, within the tolerance.
TEST(SimRun, AMoveComesOnTargetThroughFiveTimesTheNoise) {
  for (const double target : {0.002, -0.0005}) {
    SCOPED_TRACE(target);
    asked::Move move{
        {.target_rad = target, .tolerance_rad = 25e-6, .settle_s = 0.1, .timeout_s = 10.0}};
    const Outcome o = run_virtual({"sensor.sim.noise_m=2.5e-6"}, -1.0, "hil-move-noisy", 0, move);
    EXPECT_EQ(move_of(o).at("stop_cause"), "on_target");
    EXPECT_NEAR(o.rotor_theta_at_end, target, 25e-6);
    std::cout << "noisy sensor: on target at " << move_of(o).at("on_target_at_s")
              << " s, the rotor " << (o.rotor_theta_at_end - target) * 1e6
              << " urad from the target\n";
  }
}

/// The directions of the coarse steps in records [from, to] of the drive
/// (each step rises from 0 V and comes back to it): a forward sawtooth
/// rises slowly and falls fast, a reverse one the other way round.
std::vector<double> step_directions(const std::vector<double>& V, std::size_t from,
                                    std::size_t to) {
  std::vector<double> out;
  double up = 0.0, down = 0.0;
  for (std::size_t i = from + 1; i <= to; ++i) {
    up = std::max(up, V[i] - V[i - 1]);
    down = std::max(down, V[i - 1] - V[i]);
    if (V[i] == 0.0 && V[i - 1] != 0.0) {  // a step ended
      out.push_back(down > up ? 1.0 : -1.0);
      up = down = 0.0;
    }
  }
  return out;
}

// `approach = forward`: every move's last motion (the stage before the
// final release and settle) moves the rotor forward, also when the target
// lies behind the start and the move must pass it first; the rotor itself
// ends on target.
TEST(SimRun, TwentyMovesWithAForwardApproachAllArriveFromBelow) {
  constexpr double kCoarse = 1.0, kFine = 2.0, kOnTarget = 5.0;
  for (int i = 0; i < 20; ++i) {
    const double target = (i % 2 == 0 ? 1.0 : -1.0) * (0.4e-3 + 0.1e-3 * i);
    SCOPED_TRACE(target);
    asked::Move move{{.target_rad = target,
                      .tolerance_rad = 25e-6,
                      .settle_s = 0.1,
                      .timeout_s = 10.0,
                      .approach = firmware::Approach::forward}};
    const Outcome o = run_virtual({}, -1.0, "hil-move-approach", 0, move);
    ASSERT_EQ(move_of(o).at("stop_cause"), "on_target");
    EXPECT_NEAR(o.rotor_theta_at_end, target, 25e-6 + 3 * 0.5e-6 / 0.062);
    const auto& state = o.move_state;
    const auto on = std::find(state.begin(), state.end(), kOnTarget) - state.begin();
    // The last stage that moved the rotor, and where it began.
    auto last = static_cast<std::size_t>(on);
    while (last > 0 && state[last] != kCoarse && state[last] != kFine) --last;
    ASSERT_GT(last, 0u);
    std::size_t first = last;
    while (first > 0 && state[first - 1] == state[last]) --first;
    if (state[last] == kFine) {
      // The fine servo only raised the stator: in stick the rotor followed it up.
      bool raised_only = true;
      for (std::size_t k = first + 1; k <= last; ++k) {
        raised_only = raised_only && o.drive_V[k] >= o.drive_V[k - 1];
      }
      EXPECT_TRUE(raised_only) << "the fine stage lowered the stator";
    } else {
      const auto steps = step_directions(o.drive_V, first, last);
      ASSERT_FALSE(steps.empty());
      EXPECT_EQ(steps.back(), 1.0) << "the last step went backwards";
    }
    if (target < 0.0) {
      // Behind the start: the move stepped backwards past the target first.
      const auto steps = step_directions(o.drive_V, 0, static_cast<std::size_t>(on));
      EXPECT_NE(std::find(steps.begin(), steps.end(), -1.0), steps.end());
    }
  }
}

// The board's travel window ([safety] travel_min_rad/travel_max_rad from
// the zero) ends a run or a move that would leave it, at 0 V with the
// amplifier disabled, the rotor within a step of the limit (before, both
// drove on: the run to its end at about 28 mrad, the move to its target).
TEST(SimRun, ARunThatWouldLeaveTheTravelWindowStopsAtItsEdgeAndAMoveBeyondItIsRefused) {
  const double full_step = 1.4e-3;
  const Outcome run = run_virtual({"safety.travel_max_rad=0.005", "run.duration_s=2"});
  EXPECT_EQ(run.summary.stop_cause(), "travel_limit");
  EXPECT_EQ(run.summary.status(), "failed");
  EXPECT_FALSE(run.amplifier_enabled_at_end);
  EXPECT_DOUBLE_EQ(run.drive_V.back(), 0.0);
  // The rotor rides each rise forward and slips back: the window is left at
  // a rise's peak, and the run ends there, not a step later.
  double highest = -1.0;
  for (double theta : run.theta)
    highest = std::isfinite(theta) ? std::max(highest, theta) : highest;
  EXPECT_GT(highest, 0.005);
  EXPECT_LT(highest, 0.005 + full_step);
  EXPECT_LT(run.rotor_theta_at_end, 0.005);
  EXPECT_LT(run.drive_t.back(), 1.0) << "the run would have driven 2 s";
  // A move to a target outside the window is refused before anything drives.
  asked::Move far{{.target_rad = 0.05, .tolerance_rad = 25e-6, .settle_s = 0.1, .timeout_s = 10.0}};
  try {
    (void)run_virtual({"safety.travel_min_rad=-0.01", "safety.travel_max_rad=0.01"}, -1.0,
                      "hil-move-travel", 0, far);
    ADD_FAILURE() << "a move to a target beyond the travel window ran";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("outside the axis's travel window [-0.01, 0.01]"),
              std::string::npos)
        << e.what();
  }
  std::cout << "travel window: the run stopped at " << run.drive_t.back() << " s, the rotor at "
            << run.rotor_theta_at_end * 1e3 << " mrad, its highest reading " << highest * 1e3
            << " mrad (limit 5)\n";
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
  for (const auto& end :
       {"lines.sim.estop_at_s=0.3", "sensor.sim.stall_at_s=0.3", "run.duration_s=0.3"}) {
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
  const config::ConfigFile config =
      config::load_config_file(std::string(build_paths::source_dir) + "/configs/sim.toml",
                               {"run.duration_s=0.3", "run.lock_memory=false", "run.priority=0"});
  config::Rig rig = config::build_rig(config.board);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const auto dir = testing::fresh_temp_dir("hil-slow-setup");
  RunLog log = RunLog::create((dir / "run.h5").string(), {{"config", config.text}}, {"rotor"});
  const std::atomic<bool> never{false};
  const RunSummary s = execute_run(config, asked::Timed{}, std::move(rig), log, never, {});
  EXPECT_EQ(s.board.cause, firmware::StopCause::completed);
}

TEST(SimRun, EstopDisablesWithinOneDrivePeriod) {
  const Outcome o = run_virtual({"lines.sim.estop_at_s=1.0"});
  EXPECT_EQ(o.summary.board.cause, firmware::StopCause::estop);
  EXPECT_EQ(o.summary.status(), "failed");
  EXPECT_EQ(o.drive_phase.back(), static_cast<double>(firmware::DrivePhase::stopped));
  EXPECT_NEAR(o.drive_t.back(), 1.0, 1e-4 + 1e-9);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
}

// The protocol's e-stop while the drive loop is blocked in a slow drive
// write (5 s, injected in the simulated drive): the enable line drops from
// the daemon's thread at once, seen on the simulated amplifier itself, not
// when the write returns. In real time, the run on a thread of its own.
TEST(SimRun, AnEstopActsDuringASlowDriveWrite) {
  config::ConfigFile config =
      config::load_config_file(std::string(build_paths::source_dir) + "/configs/sim.toml",
                               {"drive.sim.stall_at_s=0.5", "drive.sim.stall_for_s=5",
                                "run.duration_s=10", "run.priority=0", "run.lock_memory=false"});
  config::Rig rig = config::build_rig(config.board);
  const std::shared_ptr<const hal::sim::SimRig> device = rig.sim;
  const auto dir = testing::fresh_temp_dir("hil-slow-write");
  RunLog log = RunLog::create((dir / "run.h5").string(), {{"config", config.text}}, {"rotor"});
  std::atomic<bool> stop{false}, estop{false};
  RunSummary summary;
  std::thread run([&] {
    summary = execute_run(config, asked::Timed{}, std::move(rig), log, stop, {}, &estop);
  });
  using Clock = std::chrono::steady_clock;
  const auto waited = [&](auto ready, std::chrono::milliseconds limit) {
    const auto until = Clock::now() + limit;
    while (!ready() && Clock::now() < until) std::this_thread::sleep_for(1ms);
    return ready();
  };
  const bool started = waited([&] { return device->plant().enabled(); }, 60000ms);
  EXPECT_TRUE(started);
  // The stall begins 0.5 s after the start and lasts 5 s: 1 s in, the drive
  // loop is blocked in it.
  std::this_thread::sleep_for(1000ms);
  estop.store(true);
  const auto pressed = Clock::now();
  const bool disabled = waited([&] { return !device->plant().enabled(); }, 2000ms);
  const double took_s = std::chrono::duration<double>(Clock::now() - pressed).count();
  run.join();
  log.close(summary.status());
  EXPECT_TRUE(started && disabled) << "the amplifier stayed enabled for " << took_s
                                   << " s after the e-stop, behind the blocked write";
  EXPECT_EQ(summary.board.cause, firmware::StopCause::estop);
  EXPECT_FALSE(device->plant().enabled());
}

TEST(SimRun, SensorStallRampsDownAndStops) {
  const Outcome o = run_virtual(
      {"sensor.sim.stall_at_s=1.0", "safety.sensor_stale_s=0.1", "safety.ramp_down_V_per_s=1000"});
  EXPECT_EQ(o.summary.board.cause, firmware::StopCause::sensor_fault);
  EXPECT_GT(o.summary.board.sensor.errors, 0u);
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
  const Outcome o = run_virtual({"sensor.sim.dropout_probability=0.02", "run.duration_s=1.0"});
  EXPECT_EQ(o.summary.status(), "completed");
  EXPECT_GT(o.summary.board.sensor.errors, 5u);
  EXPECT_EQ(std::count_if(o.theta.begin(), o.theta.end(), [](double v) { return std::isnan(v); }),
            static_cast<long>(o.summary.board.sensor.errors));
}

TEST(SimRun, AStopRequestRampsDownAndEndsInterrupted) {
  const Outcome o = run_virtual({"run.duration_s=10000"}, 0.2, "hil-stop");
  EXPECT_EQ(o.summary.board.cause, firmware::StopCause::interrupted);
  EXPECT_EQ(o.summary.status(), "interrupted");
  ASSERT_FALSE(o.drive_V.empty());
  EXPECT_GE(o.drive_t.back(), 0.2);
  EXPECT_DOUBLE_EQ(o.drive_V.back(), 0.0);
  EXPECT_LT(o.drive_t.back(), 10000.0);
}

// A log that fails mid-run (a file-size limit: a full disk as the writer
// sees it) ends the run; whoever follows the collector (the live view)
// still gets the rows to the run's end, the drive's stopped record
// included, and hears why the log failed.
TEST(SimRun, AFailedLogKeepsTheLiveRowsComingToTheRunsEnd) {
  const config::ConfigFile config = config::load_config_file(
      std::string(build_paths::source_dir) + "/configs/sim.toml",
      {"run.clock=virtual", "run.duration_s=60", "run.flush_interval_s=0.25"});
  config::Rig rig = config::build_rig(config.board);
  const auto dir = testing::fresh_temp_dir("hil-log-fails");
  RunLog log = RunLog::create((dir / "run.h5").string(), {{"config", config.text}}, {"rotor"});
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto previous_handler = std::signal(SIGXFSZ, SIG_IGN);  // a write past it fails instead
  rlimit small = old;
  small.rlim_cur = static_cast<rlim_t>(std::filesystem::file_size(dir / "run.h5")) + (2u << 20);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  double last_drive_phase = -1.0, last_drive_t = 0.0;
  std::string log_error;
  const std::atomic<bool> never{false};
  const RunSummary s = execute_run(
      config, asked::Timed{}, std::move(rig), log, never,
      [&](const LiveStatus& status) {
        if (!status.log_error.empty()) log_error = status.log_error;
      },
      nullptr,
      [&](const log_schema::AxesRows& axes) {
        const log_schema::LogRows& rows = axes.front();
        if (rows.drive.t.empty()) return;
        last_drive_t = rows.drive.t.back();
        last_drive_phase = rows.drive.phase.back();
      });
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, previous_handler);
  EXPECT_EQ(s.stop_cause(), "log_failed") << s.host_error;
  EXPECT_LT(last_drive_t, 60.0) << "the run went on after its log failed";
  EXPECT_EQ(last_drive_phase, static_cast<double>(firmware::DrivePhase::stopped))
      << "the rows stopped coming before the run's end, at " << last_drive_t << " s";
  EXPECT_NE(log_error.find("log"), std::string::npos) << "the live status said why: " << log_error;
}

}  // namespace
}  // namespace piezo::host
