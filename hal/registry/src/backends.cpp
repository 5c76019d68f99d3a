#include "piezo/hal/backends.hpp"

#include "piezo/hal/comedi/comedi_backends.hpp"
#include "piezo/hal/gpiod/gpiod_backends.hpp"
#include "piezo/hal/modbus/modbus_backends.hpp"
#include "piezo/hal/posix/no_lines_backend.hpp"
#include "piezo/hal/sim/sim_backends.hpp"

namespace piezo::hal {

// The first of each kind is the default.

std::vector<std::shared_ptr<DriveBackend>> drive_backends() {
  return {
      std::make_shared<sim::SimDriveBackend>(),
      std::make_shared<modbus::AnalogOutputBackend>(),
      std::make_shared<gpiod::ParallelDacBackend>(),
      std::make_shared<comedi::ComediDriveBackend>(),
  };
}

std::vector<std::shared_ptr<SensorBackend>> sensor_backends() {
  using Transport = modbus::LinkSettings::Transport;
  return {
      std::make_shared<sim::SimSensorBackend>(),
      std::make_shared<modbus::ModbusSensorBackend>(Transport::tcp),
      std::make_shared<modbus::ModbusSensorBackend>(Transport::rtu),
      std::make_shared<comedi::ComediSensorBackend>(),
  };
}

std::vector<std::shared_ptr<LinesBackend>> lines_backends() {
  return {
      std::make_shared<sim::SimLinesBackend>(),
      std::make_shared<gpiod::RigLinesBackend>(),
      std::make_shared<comedi::ComediLinesBackend>(),
      std::make_shared<posix::NoLinesBackend>(),
  };
}

}  // namespace piezo::hal
