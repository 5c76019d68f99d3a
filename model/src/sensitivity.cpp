#include "piezo/model/sensitivity.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace piezo::model {

namespace {
/// `value` to 12 significant digits: a scaled level of the paper's then
/// reads as written (0.09 * 1.2 would be 0.10799999999999998).
double rounded(double value) {
  if (value == 0.0 || !std::isfinite(value)) return value;
  const double scale =
      std::pow(10.0, 11 - static_cast<int>(std::floor(std::log10(std::abs(value)))));
  return std::round(value * scale) / scale;
}

double value_of(const Parameters& p, const std::string& name) {
  return name == "D" ? p.drive.D() : *get_parameter(p, name);
}
}  // namespace

std::vector<Sweep> paper_sweeps(const Parameters& base) {
  std::vector<Sweep> sweeps{
      {"V0", {72, 76, 80, 84, 88}},
      {"f", {8, 9, 10, 11, 12}},
      {"mu", {0.09, 0.095, 0.1, 0.105, 0.11}},
      {"D", {0.675, 0.7125, 0.75, 0.7875, 0.825}},
  };
  const Parameters table_1;
  for (auto& sweep : sweeps) {
    const double ratio = value_of(base, sweep.name) / value_of(table_1, sweep.name);
    if (ratio == 1.0) continue;  // the paper's study as printed
    for (double& level : sweep.levels) level = rounded(level * ratio);
  }
  return sweeps;
}

Parameters with_level(const Parameters& base, const std::string& name, double value) {
  Parameters p = base;
  if (name == "D") {
    p.drive.e_dr = value / p.drive.C_dr;
    return p;
  }
  const ParameterSpec* spec = find_parameter(name);
  if (spec == nullptr) throw std::invalid_argument("unknown sweep parameter '" + name + "'");
  spec->ref(p) = value;
  return p;
}

double mean_velocity(const Parameters& p, FrictionModel model, double runtime,
                     const IntegratorSettings& settings) {
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  return final_angle(p.motor, drive, model, runtime, settings) / runtime;
}

double elasticity(const std::vector<double>& levels, const std::vector<double>& velocities) {
  if (levels.size() < 2 || levels.size() != velocities.size()) {
    throw std::invalid_argument("elasticity needs matching levels and velocities, two or more");
  }
  const std::size_t mid = levels.size() / 2;
  const double v_base = velocities[mid];
  const double p_base = levels[mid];
  const double dv = (velocities.back() - velocities.front()) / v_base;
  const double dp = (levels.back() - levels.front()) / p_base;
  return dv / dp;
}

std::vector<std::string> rank_by_influence(const std::vector<SweepResult>& results) {
  std::vector<const SweepResult*> order;
  for (const auto& r : results) order.push_back(&r);
  std::stable_sort(order.begin(), order.end(), [](const SweepResult* a, const SweepResult* b) {
    return std::abs(a->elasticity) > std::abs(b->elasticity);
  });
  std::vector<std::string> names;
  for (const auto* r : order) names.push_back(r->name);
  return names;
}

}  // namespace piezo::model
