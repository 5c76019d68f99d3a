#include "piezo/hal/sim/sim_lines.hpp"

#include <utility>

namespace piezo::hal::sim {

SimLines::SimLines(const SimLinesSettings& settings, std::vector<Plant*> plants, const Clock& clock,
                   TimeNs t0)
    : settings_(settings),
      plants_(std::move(plants)),
      clock_(clock),
      t0_(t0),
      triggers_(std::make_unique<Trigger[]>(plants_.size())) {}

Status SimLines::set_trigger(std::size_t axis, bool high) {
  if (axis >= plants_.size()) return Status::io_error;
  Trigger& line = triggers_[axis];
  if (high && !line.high.load()) {
    line.last_edge_ns.store(clock_.now());
    line.edges.fetch_add(1);
  }
  line.high.store(high);
  return Status::ok;
}

Status SimLines::set_amplifier_enable(bool enabled) {
  const TimeNs now = clock_.now();
  for (Plant* plant : plants_) plant->set_enabled(now, enabled);
  return Status::ok;
}

bool SimLines::trip() {
  const TimeNs now = clock_.now();
  for (Plant* plant : plants_) plant->trip(now);
  return true;
}

Status SimLines::set_sync(bool high) {
  if (high && !sync_) sync_pulses_.fetch_add(1);
  sync_ = high;
  return Status::ok;
}

bool SimLines::button_down() const {
  const double t = since_origin_s();
  const bool held = t >= settings_.estop_at_s && t < settings_.estop_at_s + settings_.estop_hold_s;
  return held || estop_pressed_.load(std::memory_order_acquire);
}

EstopState SimLines::poll_estop() {
  bool pressed = button_down();
  // A timed press is seen by the first poll after it, however short its hold.
  if (!timed_press_seen_ && since_origin_s() >= settings_.estop_at_s) {
    pressed = true;
    timed_press_seen_ = true;
  }
  const bool edge = pressed && !estop_reported_;
  estop_reported_ = pressed;
  return {pressed, edge, Status::ok};
}

bool SimLines::reset_estop() {
  return !button_down();
}

}  // namespace piezo::hal::sim
