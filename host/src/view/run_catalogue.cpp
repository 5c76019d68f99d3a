#include "run_catalogue.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <vector>

#include "decimate.hpp"
#include "io/h5_file.hpp"
#include "io/log_schema.hpp"
#include "piezo/config/read_file.hpp"
#include "piezo/firmware/wire_keys.hpp"

namespace piezo::host::view {
namespace fs = std::filesystem;
namespace {

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) out.push_back(field);
  return out;
}

nlohmann::json series(const Series& s) {
  return {{"t", s.t}, {"y", s.y}};
}

}  // namespace

nlohmann::json list_runs(const fs::path& runs_dir) {
  nlohmann::json runs = nlohmann::json::array();
  std::ifstream in(runs_dir / "catalogue.csv");
  std::string line;
  if (!std::getline(in, line)) return runs;
  const std::vector<std::string> header = split_csv_line(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = split_csv_line(line);
    nlohmann::json row;
    for (std::size_t i = 0; i < header.size() && i < fields.size(); ++i) row[header[i]] = fields[i];
    row["has_log"] = fields.empty() ? false : run_path(runs_dir, fields[0]).has_value();
    runs.push_back(row);
  }
  std::reverse(runs.begin(), runs.end());
  return runs;
}

std::optional<fs::path> run_path(const fs::path& runs_dir, const std::string& name) {
  if (name.empty() || name == "." || name == ".." ||
      name.find_first_of("/\\") != std::string::npos) {
    return std::nullopt;
  }
  const fs::path dir = runs_dir / name;
  if (!fs::is_regular_file(dir / "run.h5")) return std::nullopt;
  return dir;
}

nlohmann::json run_plots(const fs::path& run_dir, std::size_t columns) {
  const H5File f = H5File::open((run_dir / "run.h5").string());
  using log_schema::DriveRows, log_schema::SensorRows, log_schema::ObserverRows, log_schema::path;
  const std::vector<std::string> names = log_schema::log_axes(
      f.has_attribute("/", log_schema::kAxes) ? f.attribute("/", log_schema::kAxes) : "");
  // Each axis of the run, one or several, its plots on one time axis.
  std::vector<std::string> groups;
  double t_end = 0.0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    groups.push_back(log_schema::axis_group(names, i));
    for (const std::string_view column : {path(&DriveRows::t), path(&SensorRows::t)}) {
      const std::vector<double> t = f.read(groups.back() + std::string(column));
      if (!t.empty()) t_end = std::max(t_end, t.back());
    }
  }
  const double t1 = std::max(t_end, 1e-3);
  nlohmann::json out{
      {"status", f.has_attribute("/", "status") ? f.attribute("/", "status") : "unknown"},
      {"t_end", t_end},
      {wire_key::axes, nlohmann::json::array()}};
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto read = [&](std::string_view column) {
      return f.read(groups[i] + std::string(column));
    };
    const std::vector<double> drive_t = read(path(&DriveRows::t));
    const std::vector<double> drive_V = read(path(&DriveRows::V));
    nlohmann::json axis{
        {wire_key::name, names[i]},
        {"measured", series(min_max_decimate(read(path(&SensorRows::t)),
                                             read(path(&SensorRows::theta)), 0.0, t1, columns))},
        {wire_key::drive, series(min_max_decimate(drive_t, drive_V, 0.0, t1, columns))}};
    // The zoom: the first 0.3 s of the drive, every sample.
    const auto zoom_end = std::upper_bound(drive_t.begin(), drive_t.end(), 0.3) - drive_t.begin();
    axis["zoom"] = {{"t", std::vector<double>(drive_t.begin(), drive_t.begin() + zoom_end)},
                    {"y", std::vector<double>(drive_V.begin(), drive_V.begin() + zoom_end)}};
    if (f.exists(groups[i] + std::string(path(&ObserverRows::t)))) {
      const std::vector<double> obs_t = read(path(&ObserverRows::t));
      axis["observer"] =
          series(min_max_decimate(obs_t, read(path(&ObserverRows::theta_hat)), 0.0, t1, columns));
      axis["open_loop"] =
          series(min_max_decimate(obs_t, read(path(&ObserverRows::theta_open)), 0.0, t1, columns));
    }
    out[wire_key::axes].push_back(std::move(axis));
  }
  for (const auto& [key, dataset] :
       {std::pair{"drive_timing", log_schema::kDrivePeriodErrorUs},
        std::pair{"acquire_timing", log_schema::kAcquirePeriodErrorUs}}) {
    if (f.exists(std::string(dataset))) out[key] = f.read(std::string(dataset));
  }
  out["config"] = read_file(run_dir / "config.toml").value_or("");
  return out;
}

}  // namespace piezo::host::view
