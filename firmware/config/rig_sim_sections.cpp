// The simulated rig's sections: [rig_sim] (its Modbus server's faults and
// limits) and [plant] (the simulated motor) (sections.hpp).

#include "model_config.hpp"
#include "sections.hpp"

namespace piezo::config::sections {

void read_rig_sim(SectionReader r, hal::sim::ModbusDeviceFaults& f, hal::sim::TcpLimits& tcp) {
  r.integer("max_clients", tcp.max_clients, 1, 100'000);
  r.number("frame_timeout_s", tcp.frame_timeout_s, {0.001, 60.0}, "s");
  r.number("response_delay_s", f.response_delay_s, {0.0, 10.0}, "s");
  r.number("drop_probability", f.drop_probability, {0.0, 1.0});
  r.number("exception_probability", f.exception_probability, {0.0, 1.0});
  r.number("disconnect_at_s", f.disconnect_at_s, kNonNegative, "s");
  r.number("late_reply_at_s", f.late_reply_at_s, kNonNegative, "s");
  r.number("late_reply_s", f.late_reply_s, {0.0, 10.0}, "s");
  r.number("hang_at_s", f.hang_at_s, kNonNegative, "s");
  r.number("hang_for_s", f.hang_for_s, {0.0, 3600.0}, "s");
  r.flag("times_from_drive", f.times_from_drive);
  r.integer("hand_address", f.hand_address, 0, 65535 - 64);
  r.finish();
}

void read_plant(SectionReader r, model::MotorParameters& plant_keys, AxisConfig& axis) {
  read_motor(r, plant_keys);
  r.number("end_stop_rad", axis.plant_end_stop_rad, {-10.0, 10.0}, "rad");
  r.number("coupling", axis.plant_coupling, {0.0, 0.5});
  r.finish();
}

}  // namespace piezo::config::sections
