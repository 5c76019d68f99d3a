#pragma once
/// @file
/// catalogue.csv, the list of runs beside their directories: a line per axis
/// of each run (a run of one axis has one), written when a run ends and when
/// `piezo recover` rebuilds one. A catalogue written before the axis column
/// (its last column `theta_end_rad`) is rewritten in the new shape, its runs'
/// lines keeping their figures with no axis named, before a line is added.

#include <filesystem>
#include <string>
#include <vector>

namespace piezo::host {

struct CatalogueEntry {
  std::string utc_start;
  std::string status;      ///< how the run ended (`completed`, ..., `recovered`)
  std::string stop_cause;  ///< `unknown` when recovered
  std::string config;      ///< the config's source
  double t_end_s = 0.0;
  /// How far each axis of the run got: its last measured angle, over its
  /// own sensor's radius ("" names no axis: a log that keeps none).
  struct Axis {
    std::string name;
    double angle_end_rad = 0.0;
  };
  std::vector<Axis> axes;
};

/// Appends the run in `run_dir` to catalogue.csv in its parent directory,
/// the header first when the file is new.
void append_to_catalogue(const std::filesystem::path& run_dir, const CatalogueEntry& entry);

}  // namespace piezo::host
