#pragma once
// The runs of a directory, for the web view: the catalogue (catalogue.csv,
// written by `piezo run`) and one run's plots decimated from its run.h5.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace piezo::host::view {

/// The rows of DIR/catalogue.csv, newest first (empty when there is none).
[[nodiscard]] nlohmann::json list_runs(const std::filesystem::path& runs_dir);

/// DIR/NAME when NAME is one run directory's plain name inside DIR (no
/// separators, no "..") and it holds a run.h5; nullopt otherwise.
[[nodiscard]] std::optional<std::filesystem::path> run_path(const std::filesystem::path& runs_dir,
                                                            const std::string& name);

/// One run's plots: the angle with the observer's predictions, the drive,
/// a zoom on its first periods at full rate, the loop timing histograms,
/// the status and the config text.
[[nodiscard]] nlohmann::json run_plots(const std::filesystem::path& run_dir, std::size_t columns);

}  // namespace piezo::host::view
