#include "piezo/hal/sim/sim_backends.hpp"

#include <stdexcept>

#include "piezo/hal/sim/sim_rig.hpp"

namespace piezo::hal::sim {
namespace {

using config::kNonNegative;
using config::kPositive;

SimRig& rig_of(const OpenContext& context) {
  // The builder makes the simulated rig whenever a chosen backend is simulated.
  if (!context.sim) throw std::logic_error("the simulated rig was not built");
  return *context.sim;
}

}  // namespace

std::vector<MovedKey> SimDriveBackend::moved_keys() const {
  return {{"dac_bits", "drive.sim.dac_bits"},
          {"dac_full_scale_V", "drive.sim.dac_full_scale_V"},
          {"amplifier_V_max", "drive.sim.amplifier_V_max"},
          {"amplifier_slew_V_per_s", "drive.sim.amplifier_slew_V_per_s"},
          {"stall_at_s", "drive.sim.stall_at_s"},
          {"stall_for_s", "drive.sim.stall_for_s"}};
}

void SimDriveBackend::read(config::SectionReader& r) {
  r.integer("dac_bits", dac_.bits, 4, 24);
  r.number("dac_full_scale_V", dac_.full_scale_V, {0.0, 100.0, true}, "V");
  r.number("amplifier_V_max", amplifier_.V_out_max, {0.0, 1000.0, true}, "V");
  r.number("amplifier_slew_V_per_s", amplifier_.slew_V_per_s, kPositive, "V/s");
  r.number("stall_at_s", dac_.stall_at_s, kNonNegative, "s");
  r.number("stall_for_s", dac_.stall_for_s, {0.0, 3600.0}, "s");
}

DacSettings SimDriveBackend::dac(const DriveCommon& common) const {
  DacSettings d = dac_;
  d.update_period_s = 1.0 / common.rate_hz;
  return d;
}

AmplifierSettings SimDriveBackend::amplifier(const DriveCommon& common) const {
  AmplifierSettings a = amplifier_;
  a.gain = common.amplifier_gain;
  // The signal chain interpolates over one DAC update period.
  a.ramp_time_s = 1.0 / common.rate_hz;
  return a;
}

std::shared_ptr<Drive> SimDriveBackend::open(const DriveCommon&, OpenContext& context) const {
  // Shares the rig's ownership: the drive lives as long as anyone holds it.
  return {context.sim, &rig_of(context).drive(context.axis)};
}

std::vector<MovedKey> SimSensorBackend::moved_keys() const {
  return {{"target_distance_m", "sensor.sim.target_distance_m"},
          {"noise_m", "sensor.sim.noise_m"},
          {"quantum_m", "sensor.sim.quantum_m"},
          {"latency_s", "sensor.sim.latency_s"},
          {"dropout_probability", "sensor.sim.dropout_probability"},
          {"timeout_s", "sensor.sim.timeout_s"},
          {"stall_at_s", "sensor.sim.stall_at_s"},
          {"stall_for_s", "sensor.sim.stall_for_s"},
          {"freeze_at_s", "sensor.sim.freeze_at_s"},
          {"blind_at_s", "sensor.sim.blind_at_s"},
          {"seed", "sensor.sim.seed"}};
}

void SimSensorBackend::read(config::SectionReader& r) {
  auto& s = settings_;
  // The laser's stand-off from the reflector: a distance, so above 0.
  r.number("target_distance_m", s.offset_m, {0.0, 10.0, true}, "m");
  r.number("noise_m", s.noise_m, {0.0, 1.0}, "m");
  r.number("quantum_m", s.quantum_m, {0.0, 1.0}, "m");
  r.number("latency_s", s.latency_s, {0.0, 1.0}, "s");
  r.number("dropout_probability", s.dropout_probability, {0.0, 1.0});
  r.number("timeout_s", s.timeout_s, {0.0, 10.0, true}, "s");
  r.number("stall_at_s", s.stall_at_s, kNonNegative, "s");
  r.number("stall_for_s", s.stall_for_s, kPositive, "s");
  r.number("freeze_at_s", s.freeze_at_s, kNonNegative, "s");
  r.number("blind_at_s", s.blind_at_s, kNonNegative, "s");
  int seed = static_cast<int>(s.seed);
  r.integer("seed", seed, 0, 1'000'000'000);
  s.seed = static_cast<unsigned>(seed);
}

SimSensorSettings SimSensorBackend::settings(const SensorCommon& common) const {
  SimSensorSettings s = settings_;
  s.rate_hz = common.rate_hz;
  s.r2_m = common.r2_m;
  return s;
}

std::shared_ptr<DisplacementSensor> SimSensorBackend::open(const SensorCommon&,
                                                           OpenContext& context) const {
  return {context.sim, &rig_of(context).sensor(context.axis)};
}

std::vector<MovedKey> SimLinesBackend::moved_keys() const {
  return {{"estop_at_s", "lines.sim.estop_at_s"}};
}

void SimLinesBackend::read(config::SectionReader& r) {
  r.number("estop_at_s", settings_.estop_at_s, kNonNegative, "s");
  r.number("estop_hold_s", settings_.estop_hold_s, kNonNegative, "s");
}

std::shared_ptr<DigitalLines> SimLinesBackend::open(const LinesCommon&,
                                                    OpenContext& context) const {
  return {context.sim, &rig_of(context).lines()};
}

}  // namespace piezo::hal::sim
