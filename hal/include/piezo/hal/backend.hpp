#pragma once
/// @file
/// A backend: one way to reach one kind of device (the drive, the sensor,
/// the rig's lines). Each names itself (the `backend` value that chooses
/// it), reads and checks its own config section ([drive.NAME], ...) and
/// opens its device. backends.hpp lists them; the rig builder opens the
/// chosen ones. A new backend is a folder in hal/ plus one line there.

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/config/section_reader.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/displacement_sensor.hpp"
#include "piezo/hal/drive.hpp"

namespace piezo::hal {
namespace sim {
class SimRig;
}

/// A key that once lived in the kind's own section, and its backend key now
/// ("dac_bits" -> "drive.sim.dac_bits"): an old file is refused naming it.
struct MovedKey {
  std::string_view old_key;
  std::string_view new_key;
};

/// A device resource a backend's config takes for itself (an output
/// channel, a register, a GPIO line) and the key that names it: two axes
/// of one board must not take the same one.
struct Claim {
  std::string resource;  ///< "comedi /dev/comedi0 analog output 0 (subdevice -1)"
  std::string key;       ///< the kind's key that sets it, e.g. "drive.comedi.channel"
};

/// What every drive backend takes from [drive].
struct DriveCommon {
  double rate_hz = 10'000.0;     ///< the update rate
  double amplifier_gain = 20.0;  ///< piezo volts per volt at the backend's output
  /// The rig's lines can switch the amplifier off (an enable line is wired).
  bool enable_line = true;
};

/// The prototype's reflector radius [m] (paper section 4): `sensor.r2_m`'s
/// default, and every default of a radius that comes from it.
inline constexpr double kDefaultSensorRadius_m = 0.062;

/// What every sensor backend takes from [sensor].
struct SensorCommon {
  double rate_hz = 1000.0;
  double r2_m =
      kDefaultSensorRadius_m;  ///< the reflector's radius (the simulated sensor's geometry)
};

/// What every lines backend takes from [lines]: nothing yet.
struct LinesCommon {};

/// Where a key's value came from (a file, or "--set"): for error messages.
using SourceOf = std::function<std::string(const std::string& key)>;

/// What opening a device may use.
struct OpenContext {
  Clock& clock;
  /// The simulated rig when the chosen backends are simulated (they share
  /// its plant); null otherwise.
  std::shared_ptr<sim::SimRig> sim;
  std::size_t axis = 0;  ///< which of the board's axes the device is for
};

template <class Device, class Common>
class Backend {
 public:
  Backend() = default;
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;
  virtual ~Backend() = default;

  /// The `backend` value that chooses it, e.g. "modbus-ao".
  [[nodiscard]] virtual std::string_view name() const = 0;
  /// Its section inside the kind's ([drive.modbus-ao]). Backends that
  /// differ only in transport share one: modbus-tcp and -rtu read [sensor.modbus].
  [[nodiscard]] virtual std::string_view section() const { return name(); }
  /// Part of the simulated rig: such backends come together, on one plant.
  [[nodiscard]] virtual bool simulated() const { return false; }
  /// Where its device is, for messages ("tcp 127.0.0.1:1502").
  [[nodiscard]] virtual std::string describe() const {
    return simulated() ? "simulated" : std::string(name());
  }
  /// What its device offers, for the wiring check (a card's subdevices,
  /// channels and ranges); may open the device, and throws when it cannot.
  [[nodiscard]] virtual std::string inventory() const { return describe(); }
  /// The resources its config takes (none: a backend that owns its device
  /// alone, such as the simulated rig's one plant per axis).
  [[nodiscard]] virtual std::vector<Claim> claims() const { return {}; }
  /// Keys of the kind's section that moved into this backend's.
  [[nodiscard]] virtual std::vector<MovedKey> moved_keys() const { return {}; }

  /// Reads its keys over the values so far (once per file and per --set).
  virtual void read(config::SectionReader& section) = 0;
  /// Checks the values as a whole once everything is read: always (a
  /// section names one device even when another is chosen: rig-sim serves
  /// it), and with `chosen` what only the run needs. Throws config::ConfigError.
  virtual void check(const Common& /*common*/, bool /*chosen*/, const SourceOf& /*source*/) const {}
  /// Opens the device; throws std::runtime_error when it cannot be reached.
  [[nodiscard]] virtual std::shared_ptr<Device> open(const Common& common,
                                                     OpenContext& context) const = 0;
};

using DriveBackend = Backend<Drive, DriveCommon>;
using SensorBackend = Backend<DisplacementSensor, SensorCommon>;
using LinesBackend = Backend<DigitalLines, LinesCommon>;

}  // namespace piezo::hal
