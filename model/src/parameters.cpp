#include "piezo/model/parameters.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <sstream>

namespace piezo::model {
namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

// Bounds are physical admissibility, not plausibility: a researcher may well
// explore a stiffer stack or a lighter rotor, but a zero mass is meaningless.
// Each symbol's range is what a stick-slip rotary inertia motor physically
// allows, with room for any rig this project could meet (the paper's value
// sits well inside); beyond it a value is a typo, and the model's numbers
// would be nonsense (mu = 1e308 runs and ranks).
const std::array<ParameterSpec, 15> kSpecs{{
    {"V0", "drive", "V", 0, 1000, true, true, [](Parameters& p) -> double& { return p.drive.V0; }},
    {"f", "drive", "Hz", 0, 1e5, false, true, [](Parameters& p) -> double& { return p.drive.f; }},
    {"C_dr", "drive", "-", 0, 1, false, true,
     [](Parameters& p) -> double& { return p.drive.C_dr; }},
    {"e_dr", "drive", "-", 0, 10, false, true,
     [](Parameters& p) -> double& { return p.drive.e_dr; }},
    {"d_e", "model", "m/V", 0, 1e-4, false, true,
     [](Parameters& p) -> double& { return p.motor.d_e; }},
    {"M", "model", "kg", 0, 100, false, true, [](Parameters& p) -> double& { return p.motor.M; }},
    {"J", "model", "kg m^2", 0, 1, false, true, [](Parameters& p) -> double& { return p.motor.J; }},
    {"C", "model", "N s/m", 0, 1e6, true, true, [](Parameters& p) -> double& { return p.motor.C; }},
    {"K", "model", "N/m", 0, 1e12, false, true, [](Parameters& p) -> double& { return p.motor.K; }},
    {"r", "model", "m", 0, 1, false, true, [](Parameters& p) -> double& { return p.motor.r; }},
    {"mu", "model", "-", 0, 2, false, true, [](Parameters& p) -> double& { return p.motor.mu; }},
    {"F_N", "model", "N", 0, 1e4, false, true,
     [](Parameters& p) -> double& { return p.motor.F_N; }},
    {"sigma0", "model", "N/m", 0, 1e12, false, true,
     [](Parameters& p) -> double& { return p.motor.sigma0; }},
    {"sigma1", "model", "N s/m", 0, 1e6, true, true,
     [](Parameters& p) -> double& { return p.motor.sigma1; }},
    {"sigma2", "model", "N s/m", 0, 1e6, true, true,
     [](Parameters& p) -> double& { return p.motor.sigma2; }},
}};

std::string number_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

std::string ParameterSpec::range_text() const {
  return std::string(min_inclusive ? "[" : "(") + number_text(min) + ", " + number_text(max) +
         (max_inclusive ? "]" : ")");
}

std::string differences_from_paper(const Parameters& p) {
  Parameters given = p, paper{};  // copies: ParameterSpec::ref takes them mutable
  std::string text;
  for (const ParameterSpec& spec : parameter_specs()) {
    const double value = spec.ref(given);
    if (value == spec.ref(paper)) continue;
    std::ostringstream item;
    item << spec.name << '=' << value << (spec.unit.empty() ? "" : " ") << spec.unit;
    text += (text.empty() ? "" : ", ") + item.str();
  }
  return text;
}

bool ParameterSpec::admits(double value) const {
  if (!std::isfinite(value)) return false;
  const bool above_min = min_inclusive ? value >= min : value > min;
  const bool below_max = max_inclusive ? value <= max : value < max;
  return above_min && below_max;
}

std::span<const ParameterSpec> parameter_specs() {
  return kSpecs;
}

const ParameterSpec* find_parameter(std::string_view name) {
  for (const auto& spec : kSpecs) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

std::optional<double> get_parameter(const Parameters& p, std::string_view name) {
  const ParameterSpec* spec = find_parameter(name);
  if (spec == nullptr) return std::nullopt;
  Parameters copy = p;
  return spec->ref(copy);
}

std::vector<ParameterIssue> validate(const Parameters& p) {
  std::vector<ParameterIssue> issues;
  Parameters copy = p;
  for (const auto& spec : kSpecs) {
    const double value = spec.ref(copy);
    if (!spec.admits(value)) {
      issues.push_back(
          {std::string(spec.name), std::string(spec.name) + " = " + number_text(value) + " " +
                                       std::string(spec.unit) + " is outside the allowed range " +
                                       spec.range_text()});
    }
  }
  const double D = p.drive.D();
  if (std::isfinite(D) && !(D > 0 && D < 1)) {
    issues.push_back({"C_dr*e_dr", "D = C_dr*e_dr = " + number_text(D) +
                                       " is outside the allowed range (0, 1)"});
  }
  return issues;
}

}  // namespace piezo::model
