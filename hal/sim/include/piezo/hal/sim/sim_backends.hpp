#pragma once
/// @file
/// The simulated rig's backends, each `sim`: [drive.sim] (the DAC and the
/// amplifier), [sensor.sim] (the laser sensor) and [lines.sim] (the
/// e-stop's schedule). They share one plant, so the rig builder makes one
/// SimRig from their three sections and each opens its part of it.

#include "piezo/hal/backend.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"

namespace piezo::hal::sim {

class SimDriveBackend final : public DriveBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "sim"; }
  [[nodiscard]] bool simulated() const override { return true; }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  void read(config::SectionReader& section) override;
  [[nodiscard]] std::shared_ptr<Drive> open(const DriveCommon& common,
                                            OpenContext& context) const override;

  /// The simulated DAC, latching at the drive rate.
  [[nodiscard]] DacSettings dac(const DriveCommon& common) const;
  /// The simulated amplifier, its gain [drive]'s, smoothing over one update.
  [[nodiscard]] AmplifierSettings amplifier(const DriveCommon& common) const;

 private:
  DacSettings dac_;
  AmplifierSettings amplifier_;
};

class SimSensorBackend final : public SensorBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "sim"; }
  [[nodiscard]] bool simulated() const override { return true; }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  void read(config::SectionReader& section) override;
  [[nodiscard]] std::shared_ptr<DisplacementSensor> open(const SensorCommon& common,
                                                         OpenContext& context) const override;

  /// The simulated sensor at [sensor]'s rate and radius.
  [[nodiscard]] SimSensorSettings settings(const SensorCommon& common) const;

 private:
  SimSensorSettings settings_;
};

class SimLinesBackend final : public LinesBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "sim"; }
  [[nodiscard]] bool simulated() const override { return true; }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  void read(config::SectionReader& section) override;
  [[nodiscard]] std::shared_ptr<DigitalLines> open(const LinesCommon& common,
                                                   OpenContext& context) const override;

  [[nodiscard]] const SimLinesSettings& settings() const { return settings_; }

 private:
  SimLinesSettings settings_;
};

}  // namespace piezo::hal::sim
