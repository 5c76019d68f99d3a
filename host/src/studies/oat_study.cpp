#include "oat_study.hpp"

#include <fmt/format.h>

#include "jobs/interruption.hpp"
#include "config/model_config.hpp"
#include "jobs/parallel.hpp"
#include "jobs/progress.hpp"

namespace piezo::host {

namespace {
constexpr double kTraceInterval = 1e-3;  // angle traces for the plots [s]
}

OatStudy oat_study(const model::Parameters& base, model::FrictionModel friction) {
  const auto sweeps = model::paper_sweeps(base);
  OatStudy study;
  for (std::size_t s = 0; s < sweeps.size(); ++s) {
    for (std::size_t l = 0; l < sweeps[s].levels.size(); ++l) study.runs.push_back({s, l, {}});
  }
  // Validate every level before spending time on any run.
  for (const auto& run : study.runs) {
    const auto& sw = sweeps[run.sweep];
    config::require_valid(model::with_level(base, sw.name, sw.levels[run.level]),
                          fmt::format("sweep {}={}", sw.name, sw.levels[run.level]));
  }
  const auto times = model::uniform_times(model::kSensitivityRuntime, kTraceInterval);
  auto& runs = study.runs;
  parallel_for(
      runs.size(),
      [&](std::size_t i) {
        const auto& sw = sweeps[runs[i].sweep];
        const model::Parameters p = model::with_level(base, sw.name, sw.levels[runs[i].level]);
        const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
        runs[i].trace = model::simulate(p.motor, drive, friction, times, interruptible());
      },
      counted_progress("sensitivity", "runs"));

  for (std::size_t s = 0; s < sweeps.size(); ++s) {
    model::SweepResult r{sweeps[s].name, sweeps[s].levels, {}, 0.0};
    for (const auto& run : runs) {
      if (run.sweep == s)
        r.mean_velocity.push_back(run.trace.theta.back() / model::kSensitivityRuntime);
    }
    r.elasticity = model::elasticity(r.levels, r.mean_velocity);
    study.results.push_back(std::move(r));
  }
  study.ranking = model::rank_by_influence(study.results);
  return study;
}

nlohmann::json to_json(const OatStudy& study, std::string_view model) {
  nlohmann::json params = nlohmann::json::array();
  for (const auto& r : study.results) {
    params.push_back({{"name", r.name},
                      {"levels", r.levels},
                      {"mean_velocity_rad_s", r.mean_velocity},
                      {"elasticity", r.elasticity}});
  }
  return {{"model", model},
          {"runtime_s", model::kSensitivityRuntime},
          {"parameters", params},
          {"ranking", study.ranking}};
}

}  // namespace piezo::host
