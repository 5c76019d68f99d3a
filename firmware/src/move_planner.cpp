#include "piezo/firmware/move_planner.hpp"

#include <algorithm>

#include "piezo/firmware/request_limits.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {

const StepTable& MovePlanner::steps(double V0, double f, double D) {
  const auto key = std::make_tuple(V0, f, D);
  if (const auto it = tables_.find(key); it != tables_.end()) return it->second;
  StepTable table;
  const double rad_per_V = motor_.d_e / motor_.r;
  for (std::size_t i = 0; i < MoveSettings::kStepFractions.size(); ++i) {
    const double V = MoveSettings::kStepFractions[i] * V0;
    const double floor = 1e-3 * rad_per_V * V;
    table.forward_rad[i] = std::max(
        floor,
        model::final_angle(motor_, model::Sawtooth(V, f, D), model::FrictionModel::lugre, 1.0 / f));
    table.reverse_rad[i] =
        std::max(floor, -model::final_angle(motor_, model::Sawtooth(V, f, 1.0 - D),
                                            model::FrictionModel::lugre, 1.0 / f));
  }
  return tables_.emplace(key, table).first->second;
}

void MovePlanner::plan(MoveSettings& m, bool alternatives, double rate_hz, double slew_V_per_s) {
  m.rad_per_V = motor_.d_e / motor_.r;
  const StepTable& own = steps(m.V0, m.f, m.D);
  m.step_forward_rad = own.forward_rad;
  m.step_reverse_rad = own.reverse_rad;
  if (!alternatives) return;
  // For when the steps come out far smaller than predicted.
  const double slew_f_max = slew_V_per_s * std::min(m.D, 1.0 - m.D) / m.V0;
  for (const double factor : {2.0, 4.0}) {
    const double fa = factor * m.f;
    if (fa > max_drive_frequency(rate_hz) || fa > slew_f_max) break;
    auto& a = m.alternatives[static_cast<std::size_t>(m.alternative_count++)];
    const StepTable& t = steps(m.V0, fa, m.D);
    a.f = fa;
    a.forward_rad = t.forward_rad;
    a.reverse_rad = t.reverse_rad;
  }
}

}  // namespace piezo::firmware
