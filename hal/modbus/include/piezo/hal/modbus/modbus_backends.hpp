#pragma once
/// @file
/// The Modbus backends: the laser sensor's registers over TCP or RTU
/// (`modbus-tcp`, `modbus-rtu`, both reading [sensor.modbus], with presets
/// for known sensors) and an analog-output module's holding register as
/// the drive (`modbus-ao`, [drive.modbus-ao]).

#include "piezo/hal/backend.hpp"
#include "piezo/hal/modbus/link.hpp"
#include "piezo/hal/modbus/modbus_analog_output.hpp"
#include "piezo/hal/modbus/register_map.hpp"

namespace piezo::hal::modbus {

/// The Baumer OM20/OM30 map: FC04, register 202, f32 CDAB in millimetres, 57600 8E1, unit 1.
void apply_baumer_om30(LinkSettings& link, RegisterMap& map);

class ModbusSensorBackend final : public SensorBackend {
 public:
  explicit ModbusSensorBackend(LinkSettings::Transport transport);

  [[nodiscard]] std::string_view name() const override;
  [[nodiscard]] std::string_view section() const override { return "modbus"; }
  [[nodiscard]] std::string describe() const override { return link_.describe(); }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  [[nodiscard]] std::vector<Claim> claims() const override;
  /// Reads `preset` first, then the link's and the map's keys over it.
  void read(config::SectionReader& section) override;
  void check(const SensorCommon& common, bool chosen, const SourceOf& source) const override;
  [[nodiscard]] std::shared_ptr<DisplacementSensor> open(const SensorCommon& common,
                                                         OpenContext& context) const override;

  [[nodiscard]] const LinkSettings& link() const { return link_; }
  [[nodiscard]] const RegisterMap& map() const { return map_; }

 private:
  LinkSettings link_;
  RegisterMap map_;
};

/// How a Modbus analog output is guarded against a dead link.
struct AnalogOutputGuard {
  double watchdog_s = 0.0;              ///< the module watchdog's timeout (0: none configured)
  bool link_loss_acknowledged = false;  ///< the config accepts a module that holds its value
};

class AnalogOutputBackend final : public DriveBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "modbus-ao"; }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  [[nodiscard]] std::vector<Claim> claims() const override;
  void read(config::SectionReader& section) override;
  void check(const DriveCommon& common, bool chosen, const SourceOf& source) const override;
  [[nodiscard]] std::shared_ptr<Drive> open(const DriveCommon& common,
                                            OpenContext& context) const override;

  /// The module's register and scaling, at [drive]'s amplifier gain.
  [[nodiscard]] AnalogOutputSettings settings(const DriveCommon& common) const;
  [[nodiscard]] const LinkSettings& link() const { return link_; }

 private:
  LinkSettings link_;
  AnalogOutputSettings ao_;
  AnalogOutputGuard guard_;
};

}  // namespace piezo::hal::modbus
