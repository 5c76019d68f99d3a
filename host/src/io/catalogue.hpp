#pragma once
/// @file
/// catalogue.csv, the list of runs beside their directories: one line per
/// run, written when a run ends and when `piezo recover` rebuilds one.

#include <filesystem>
#include <string>

namespace piezo::host {

struct CatalogueEntry {
  std::string utc_start;
  std::string status;      ///< how the run ended (`completed`, ..., `recovered`)
  std::string stop_cause;  ///< `unknown` when recovered
  std::string config;      ///< the config's source
  double t_end_s = 0.0;
  double theta_end_rad = 0.0;
};

/// Appends the run in `run_dir` to catalogue.csv in its parent directory,
/// the header first when the file is new.
void append_to_catalogue(const std::filesystem::path& run_dir, const CatalogueEntry& entry);

}  // namespace piezo::host
