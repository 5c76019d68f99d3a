#include "piezo/hal/sim/sim_rig.hpp"

namespace piezo::hal::sim {

SimRig::SimRig(const std::vector<SimAxisSettings>& axes, const SimLinesSettings& lines,
               Clock& clock, TimeNs t0) {
  std::vector<Plant*> plants;
  for (const SimAxisSettings& s : axes) {
    plants.push_back(&axes_.emplace_back(std::make_unique<Axis>(s, clock, t0))->plant);
  }
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i].coupling == 0.0) continue;
    for (std::size_t j = 0; j < axes.size(); ++j) {
      if (j != i) axes_[j]->plant.couple_to(axes_[i]->plant, axes[i].coupling);
    }
  }
  lines_ = std::make_unique<SimLines>(lines, std::move(plants), clock, t0);
}

void SimRig::advance_to(TimeNs t) {
  for (const auto& a : axes_) a->plant.advance(t);
}

void SimRig::set_time_origin(TimeNs t0) {
  for (const auto& a : axes_) {
    a->drive.set_time_origin(t0);
    a->sensor.set_time_origin(t0);
  }
  lines_->set_time_origin(t0);
}

}  // namespace piezo::hal::sim
