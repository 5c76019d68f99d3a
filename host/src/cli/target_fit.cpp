#include "target_fit.hpp"

#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "config/model_config.hpp"
#include "io/fit_io.hpp"
#include "piezo/config/config_error.hpp"

namespace piezo::host {
namespace {

/// NaN (a figure the fit does not define) as JSON's null.
nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

std::string settings_text(const model::TravelTarget& t) {
  std::string s;
  for (const auto& [name, value] : t.settings) s += fmt::format("{}={:g}, ", name, value);
  return s;
}

/// "a,b@2,c" as its items, spaces around each dropped.
std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> items;
  std::size_t begin = 0;
  while (begin <= list.size()) {
    const std::size_t end = std::min(list.find(',', begin), list.size());
    std::string item = list.substr(begin, end - begin);
    item.erase(0, item.find_first_not_of(' '));
    item.erase(item.find_last_not_of(' ') + 1);
    items.push_back(item);
    begin = end + 1;
  }
  return items;
}

}  // namespace

int run_target_fit(const TargetFitOptions& o) {
  const auto friction = model::parse_friction_model(o.model);
  if (!friction) throw config::ConfigError("--model", o.model, "allowed: lugre, coulomb");
  std::vector<model::TravelTarget> targets;
  for (const auto& text : o.targets) targets.push_back(parse_travel_target(text));
  const model::Parameters start =
      o.config.empty() ? model::Parameters{} : config::load_model_config(o.config);
  model::FitSettings settings = cli_target_fit_settings(
      checked_target_free_parameters(
          o.params.empty() ? std::nullopt : std::optional(split_list(o.params)), *friction,
          targets.size(), "identify", "--params"),
      *friction, "identify");
  settings.max_iterations = o.max_iterations;
  if (settings.free.size() > targets.size()) {
    throw config::ConfigError(
        "--params", fmt::format("{} parameters", settings.free.size()),
        fmt::format("{} targets fix at most {} free parameters; name them with --params",
                    targets.size(), targets.size()));
  }
  const model::TargetFitResult r = model::fit_travel_targets(start, targets, settings);

  if (!o.out.empty()) {
    write_parameters_toml(
        o.out, r.fit.parameters,
        fmt::format("piezo identify --target ({} model, {} targets)", o.model, targets.size()));
  }
  if (o.json) {
    nlohmann::json parameters, errors, intervals, met = nlohmann::json::array();
    for (const auto& f : r.fit.fitted) {
      parameters[f.name] = f.value;
      errors[f.name] = number_or_null(f.standard_error);
      intervals[f.name] =
          std::isfinite(f.low95) ? nlohmann::json{f.low95, f.high95} : nlohmann::json(nullptr);
    }
    for (std::size_t i = 0; i < targets.size(); ++i) {
      nlohmann::json settings_json = nlohmann::json::object();
      for (const auto& [name, value] : targets[i].settings) settings_json[name] = value;
      met.push_back({{"settings", settings_json},
                     {"angle_rad", targets[i].angle_rad},
                     {"time_s", targets[i].time_s},
                     {"model_time_s", number_or_null(r.targets[i].model_time_s)},
                     {"relative_error", number_or_null(r.targets[i].relative_error)},
                     {"initial_model_time_s", number_or_null(r.initial_targets[i].model_time_s)}});
    }
    std::cout << nlohmann::json{{"model", o.model},
                                {"parameters", parameters},
                                {"standard_errors", errors},
                                {"confidence_95", intervals},
                                {"targets", met},
                                {"iterations", r.fit.iterations},
                                {"converged", r.fit.converged},
                                {"stop_reason", r.fit.stop_reason},
                                {"notes", r.fit.notes}}
                     .dump()
              << "\n";
    return 0;
  }
  fmt::print("{} model on {} targets after {} iterations, {}\n", o.model, targets.size(),
             r.fit.iterations, r.fit.stop_reason);
  for (const auto& f : r.fit.fitted) {
    if (std::isfinite(f.low95)) {
      fmt::print("  {:<7} = {:.6g} +- {:.2g}   (95 %: {:.6g} .. {:.6g})\n", f.name, f.value,
                 f.standard_error, f.low95, f.high95);
    } else {
      fmt::print("  {:<7} = {:.6g}\n", f.name, f.value);
    }
  }
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const auto& t = targets[i];
    fmt::print("  target {}angle {:g} rad in {:g} s: model {:.4g} s ({:+.2f} %; from {:.4g} s)\n",
               settings_text(t), t.angle_rad, t.time_s, r.targets[i].model_time_s,
               100.0 * r.targets[i].relative_error, r.initial_targets[i].model_time_s);
  }
  for (const auto& note : r.fit.notes) fmt::print("  note: {}\n", note);
  if (!o.out.empty()) fmt::print("fitted parameters written to {}\n", o.out);
  return 0;
}

}  // namespace piezo::host
