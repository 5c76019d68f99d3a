#pragma once
/// @file
/// The DAQ card's backends, each `comedi`: the drive on a clocked analog
/// output ([drive.comedi]), the sensor on a clocked analog input
/// ([sensor.comedi]) and the enable, sync and e-stop lines on its digital
/// I/O ([lines.comedi]), through comedilib.

#include "piezo/hal/backend.hpp"
#include "piezo/hal/comedi/comedi_analog_input.hpp"
#include "piezo/hal/comedi/comedi_analog_output.hpp"
#include "piezo/hal/comedi/comedi_digital_lines.hpp"

namespace piezo::hal::comedi {

class ComediDriveBackend final : public DriveBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "comedi"; }
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] std::string inventory() const override;
  [[nodiscard]] std::vector<Claim> claims() const override;
  void read(config::SectionReader& section) override;
  [[nodiscard]] std::shared_ptr<Drive> open(const DriveCommon& common,
                                            OpenContext& context) const override;

  /// The output at [drive]'s rate and amplifier gain.
  [[nodiscard]] AnalogOutputSettings settings(const DriveCommon& common) const;

 private:
  AnalogOutputSettings settings_;
};

class ComediSensorBackend final : public SensorBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "comedi"; }
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] std::string inventory() const override;
  [[nodiscard]] std::vector<Claim> claims() const override;
  void read(config::SectionReader& section) override;
  void check(const SensorCommon& common, bool chosen, const SourceOf& source) const override;
  [[nodiscard]] std::shared_ptr<DisplacementSensor> open(const SensorCommon& common,
                                                         OpenContext& context) const override;

  /// The input at [sensor]'s rate.
  [[nodiscard]] AnalogInputSettings settings(const SensorCommon& common) const;

 private:
  AnalogInputSettings settings_;
};

class ComediLinesBackend final : public LinesBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "comedi"; }
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] std::string inventory() const override;
  void read(config::SectionReader& section) override;
  [[nodiscard]] std::shared_ptr<DigitalLines> open(const LinesCommon& common,
                                                   OpenContext& context) const override;

 private:
  DigitalLinesSettings settings_;
};

}  // namespace piezo::hal::comedi
