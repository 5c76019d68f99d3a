#pragma once
// What `piezo calibrate` does once the board's experiment has run: the
// model fitted to the experiment's full-amplitude steps (the existing
// identification), the calibration file with that fit beside the board's
// measurements, a plot and a one-page summary in the run directory, and the
// fitted calibration given back to the board (the one in this process
// keeps it in the config's [piezod] calibration_file) so that later moves
// and observers use it.

#include <filesystem>
#include <nlohmann/json.hpp>

#include "run/board_client.hpp"
#include "config/config_file.hpp"

namespace piezo::host {

struct CalibrationReport {
  nlohmann::json calibration;  ///< as installed (with the fit under "model")
  std::string kept;            ///< where the board keeps it, in words
  std::filesystem::path file, plot, summary;
};

/// `board_calibration`: what the board measured (its run summary's
/// "calibration"); `log`: the experiment's run.h5; `client`: the board that
/// ran it, `local` when it is the one in this process. Progress on stderr.
[[nodiscard]] CalibrationReport finish_calibration(const std::filesystem::path& dir,
                                                   const std::filesystem::path& log,
                                                   const nlohmann::json& board_calibration,
                                                   const config::ConfigFile& config,
                                                   BoardClient& client, bool local);

}  // namespace piezo::host
