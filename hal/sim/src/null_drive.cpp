#include "piezo/hal/sim/null_drive.hpp"

namespace piezo::hal::sim {

Status NullDrive::write(double volts) {
  if (latency_ > 0) clock_.sleep_until(clock_.now() + latency_);
  acknowledged_V_ = volts;
  return Status::ok;
}

}  // namespace piezo::hal::sim
