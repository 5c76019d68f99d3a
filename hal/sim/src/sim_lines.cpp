#include "piezo/hal/sim/sim_lines.hpp"

namespace piezo::hal::sim {

SimLines::SimLines(const SimLinesSettings& settings, Plant& plant, const Clock& clock, TimeNs t0)
    : settings_(settings), plant_(plant), clock_(clock), t0_(t0) {}

Status SimLines::set_amplifier_enable(bool enabled) {
  plant_.set_enabled(clock_.now(), enabled);
  return Status::ok;
}

bool SimLines::trip() {
  plant_.trip(clock_.now());
  return true;
}

Status SimLines::set_sync(bool high) {
  if (high && !sync_) sync_pulses_.fetch_add(1);
  sync_ = high;
  return Status::ok;
}

EstopState SimLines::poll_estop() {
  if (to_seconds(clock_.now() - t0_) >= settings_.estop_at_s) press_estop();
  const bool pressed = estop_pressed_.load(std::memory_order_acquire);
  const bool edge = pressed && !estop_reported_;
  estop_reported_ = pressed;
  return {pressed, edge, Status::ok};
}

}  // namespace piezo::hal::sim
