#pragma once
// What `piezo calibrate` does once the board's experiment has run: the
// model fitted to the experiment's full-amplitude steps (the existing
// identification), the calibration file with that fit beside the board's
// measurements, a plot and a one-page summary in the run directory, and the
// fitted calibration given back to the board (the one in this process
// keeps it in the config's [piezod] calibration_file) so that later moves
// and observers use it.

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "config/config_file.hpp"
#include "piezo/protocol/messages.hpp"
#include "run/board_client.hpp"

namespace piezo::host {

using Calibration = protocol::CalibrationRecord;

/// The model fitted to a calibration's steps, as the record keeps it (its
/// `model`; the board keeps it as given).
struct CalibrationFit {
  std::string friction = "lugre";  ///< the model's name (`piezo identify --model`)
  std::map<std::string, double> parameters;
  std::map<std::string, std::vector<double>> confidence_95;  ///< [low, high] each
  double rmse_rad = 0.0, initial_rmse_rad = 0.0;
  bool converged = false;
  std::vector<double> window_s;  ///< [begin, end] of the log fitted
  std::vector<std::string> notes;
};
void to_json(nlohmann::json& j, const CalibrationFit& m);
void from_json(const nlohmann::json& j, CalibrationFit& m);

/// The record's fitted model, if it has one (a record from another host
/// may hold one this host cannot read: none then).
[[nodiscard]] std::optional<CalibrationFit> fit_of(const Calibration& c);

struct CalibrationReport {
  Calibration calibration;  ///< as installed (with the fit as its model)
  std::string kept;         ///< where the board keeps it, in words
  std::filesystem::path file, plot, summary;
};

/// `board_calibration`: what the board measured (its run summary's
/// "calibration"); `axis`: the board's axis it calibrated; `log`: the
/// experiment's run.h5; `client`: the board that ran it, `local` when it is
/// the one in this process. Progress on stderr.
[[nodiscard]] CalibrationReport finish_calibration(const std::filesystem::path& dir,
                                                   const std::filesystem::path& log,
                                                   const Calibration& board_calibration,
                                                   const std::string& axis,
                                                   const config::ConfigFile& config,
                                                   BoardClient& client, bool local);

}  // namespace piezo::host
