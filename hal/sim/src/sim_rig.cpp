#include "piezo/hal/sim/sim_rig.hpp"

namespace piezo::hal::sim {

SimRig::SimRig(const SimRigSettings& settings, Clock& clock, TimeNs t0)
    : plant_(settings.plant, settings.amplifier, t0, settings.end_stop_rad),
      drive_(settings.dac, plant_, clock, t0),
      sensor_(settings.sensor, plant_, clock, t0),
      lines_(settings.lines, plant_, clock, t0) {}

void SimRig::set_time_origin(TimeNs t0) {
  drive_.set_time_origin(t0);
  sensor_.set_time_origin(t0);
  lines_.set_time_origin(t0);
}

}  // namespace piezo::hal::sim
