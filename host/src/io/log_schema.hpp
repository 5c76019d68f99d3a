#pragma once
// The run log's layout, declared once: each dataset's path beside the
// buffer column it is written from. The writer (RunLog) creates and
// appends exactly these; the readers (identify, compare, report) find a
// dataset's path by its column, never by a string of their own.
//
// All datasets are 1-D, chunked and compressed (shuffle + deflate, read by
// h5py and MATLAB without plugins): float64 for times and values (no loss
// of precision), uint8 for the small codes (phase, status, move_state);
// times in seconds from the run's start.
//   /drive/t, /drive/V, /drive/phase, /drive/status, /drive/move_state (a
//   closed-loop move's state, by firmware::kMoveStateNames: 0 none,
//   1 coarse, 2 fine, 3 release, 4 settle, 5 on_target, 6 stalled,
//   7 sensor_implausible, 8 holding)
//   /sensor/t (request time), /sensor/t_response, /sensor/displacement_m,
//   /sensor/theta (NaN where the reading failed), /sensor/status
//   /drive/t_received, /sensor/t_received: when the host received each
//   sample, mapped onto the board's clock (attribute board_clock_offset_ns;
//   on the virtual clock: the host's wall time since the start)
//   /observer/t, theta_hat, theta_dot_hat, x_hat, z_hat, F_hat, residual
//   (measured minus predicted, before correction), theta_open (open loop)
//   /timing/drive_period_error_us, /timing/acquire_period_error_us (histogram
//   counts, 1 us bins), written whole at the end.
//   /triggers/k, position_rad, angle_rad, reading_s, edge_s, late: a scan's
//   trigger pulses, one row each, as they were streamed (a pulse the
//   stream lost is added from the board's summary at the end: sort by k).
//
// A run of several axes (a group move) keeps each axis's /drive, /sensor
// and /observer under the axis's group, /axes/NAME (/axes/theta/drive/V),
// with that axis's own attributes on the group; the root attribute "axes"
// names them in the run's order. A run of one axis keeps them at the root,
// as above, whichever board axis it drove.

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace piezo::host::log_schema {

using Column = std::vector<double>;

struct DriveRows {
  Column t, V, phase, status, move_state, t_received;
};
struct SensorRows {
  Column t, t_response, displacement_m, theta, status, t_received;
};
struct ObserverRows {
  Column t, theta_hat, theta_dot_hat, x_hat, z_hat, F_hat, residual, theta_open;
};
struct TriggerRows {
  Column k, position_rad, angle_rad, reading_s, edge_s, late;
};

/// Samples waiting to be appended: one typed column per dataset, so adding
/// a sample is a push_back, not a lookup.
struct LogRows {
  DriveRows drive;
  SensorRows sensor;
  ObserverRows observer;
  TriggerRows triggers;
};

/// One LogRows per axis of a run, in the run's order (a run of one axis: one).
using AxesRows = std::vector<LogRows>;

/// The group an axis's datasets and attributes are under: "/axes/NAME",
/// for a log of one axis as of several. A log written before this layout
/// (no root attribute "axes") kept its one axis at the root: its readers
/// take it as the one unnamed axis "", whose group is "" (the root).
inline std::string axis_group(const std::vector<std::string>& axes, std::size_t i) {
  return axes[i].empty() ? std::string() : "/axes/" + axes[i];
}

/// Whether `axes` is the one unnamed axis of a log written before /axes.
inline bool at_root(const std::vector<std::string>& axes) {
  return axes.size() == 1 && axes.front().empty();
}

/// Splits the root attribute "axes" ("theta,phi") into names; none: a log
/// written before /axes.
inline std::vector<std::string> split_axes(std::string_view list) {
  std::vector<std::string> out;
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    out.emplace_back(list.substr(0, comma));
    list = comma == std::string_view::npos ? std::string_view() : list.substr(comma + 1);
  }
  return out;
}

/// A log's axes from its root attribute "axes" (empty: a log written
/// before /axes, its one unnamed axis "" at the root).
inline std::vector<std::string> log_axes(std::string_view axes_attribute) {
  std::vector<std::string> axes = split_axes(axes_attribute);
  if (axes.empty()) axes.emplace_back();
  return axes;
}

/// How a dataset is stored in the file (its buffer column is double).
enum class Storage { float64, uint8 };

template <class Rows>
struct Dataset {
  std::string_view path;
  Column Rows::*column;
  Storage storage = Storage::float64;
};

inline constexpr std::array kDrive{
    Dataset<DriveRows>{"/drive/t", &DriveRows::t},
    Dataset<DriveRows>{"/drive/V", &DriveRows::V},
    Dataset<DriveRows>{"/drive/phase", &DriveRows::phase, Storage::uint8},
    Dataset<DriveRows>{"/drive/status", &DriveRows::status, Storage::uint8},
    Dataset<DriveRows>{"/drive/move_state", &DriveRows::move_state, Storage::uint8},
    Dataset<DriveRows>{"/drive/t_received", &DriveRows::t_received},
};
inline constexpr std::array kSensor{
    Dataset<SensorRows>{"/sensor/t", &SensorRows::t},
    Dataset<SensorRows>{"/sensor/t_response", &SensorRows::t_response},
    Dataset<SensorRows>{"/sensor/displacement_m", &SensorRows::displacement_m},
    Dataset<SensorRows>{"/sensor/theta", &SensorRows::theta},
    Dataset<SensorRows>{"/sensor/status", &SensorRows::status, Storage::uint8},
    Dataset<SensorRows>{"/sensor/t_received", &SensorRows::t_received},
};
inline constexpr std::array kObserver{
    Dataset<ObserverRows>{"/observer/t", &ObserverRows::t},
    Dataset<ObserverRows>{"/observer/theta_hat", &ObserverRows::theta_hat},
    Dataset<ObserverRows>{"/observer/theta_dot_hat", &ObserverRows::theta_dot_hat},
    Dataset<ObserverRows>{"/observer/x_hat", &ObserverRows::x_hat},
    Dataset<ObserverRows>{"/observer/z_hat", &ObserverRows::z_hat},
    Dataset<ObserverRows>{"/observer/F_hat", &ObserverRows::F_hat},
    Dataset<ObserverRows>{"/observer/residual", &ObserverRows::residual},
    Dataset<ObserverRows>{"/observer/theta_open", &ObserverRows::theta_open},
};

inline constexpr std::array kTriggers{
    Dataset<TriggerRows>{"/triggers/k", &TriggerRows::k},
    Dataset<TriggerRows>{"/triggers/position_rad", &TriggerRows::position_rad},
    Dataset<TriggerRows>{"/triggers/angle_rad", &TriggerRows::angle_rad},
    Dataset<TriggerRows>{"/triggers/reading_s", &TriggerRows::reading_s},
    Dataset<TriggerRows>{"/triggers/edge_s", &TriggerRows::edge_s},
    Dataset<TriggerRows>{"/triggers/late", &TriggerRows::late, Storage::uint8},
};

constexpr const auto& datasets(const DriveRows*) {
  return kDrive;
}
constexpr const auto& datasets(const SensorRows*) {
  return kSensor;
}
constexpr const auto& datasets(const ObserverRows*) {
  return kObserver;
}
constexpr const auto& datasets(const TriggerRows*) {
  return kTriggers;
}

/// The path of the dataset written from `column`, e.g. path(&DriveRows::V).
template <class Rows>
std::string path(Column Rows::*column) {
  for (const auto& d : datasets(static_cast<const Rows*>(nullptr)))
    if (d.column == column) return std::string(d.path);
  return {};
}

/// How the dataset at `path` is stored (an axis's group before it or not).
inline Storage storage(std::string_view path) {
  for (const auto& d : kDrive)
    if (path.ends_with(d.path)) return d.storage;
  for (const auto& d : kSensor)
    if (path.ends_with(d.path)) return d.storage;
  for (const auto& d : kTriggers)
    if (path.ends_with(d.path)) return d.storage;
  return Storage::float64;
}

/// Calls f(path, column) for every dataset of `rows`, group by group.
template <class F>
void for_each_column(LogRows& rows, F&& f) {
  for (const auto& d : kDrive) f(d.path, rows.drive.*d.column);
  for (const auto& d : kSensor) f(d.path, rows.sensor.*d.column);
  for (const auto& d : kObserver) f(d.path, rows.observer.*d.column);
  for (const auto& d : kTriggers) f(d.path, rows.triggers.*d.column);
}

/// Calls f(path, column) for every dataset of every axis of `rows`, each
/// path under its axis's group (axis_group).
template <class F>
void for_each_column(AxesRows& rows, const std::vector<std::string>& axes, F&& f) {
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::string group = axis_group(axes, i);
    for_each_column(rows[i], [&](std::string_view path, Column& column) {
      f(std::string_view(group + std::string(path)), column);
    });
  }
}

// Written whole at the end of a run.
inline constexpr const char* kDrivePeriodErrorUs = "/timing/drive_period_error_us";
inline constexpr const char* kAcquirePeriodErrorUs = "/timing/acquire_period_error_us";

// Root attributes, every one a writer sets (docs/run-logs.md says what
// each holds); writers and readers name them by these, never by a string.
inline constexpr const char* kStatus = "status";
inline constexpr const char* kModelParameters = "model_parameters";
inline constexpr const char* kDriveLatency = "drive_latency_s";
inline constexpr const char* kConfig = "config";
inline constexpr const char* kConfigSource = "config_source";
inline constexpr const char* kPlantParameters = "plant_parameters";
inline constexpr const char* kVersion = "version";
inline constexpr const char* kUtcStart = "utc_start";
inline constexpr const char* kHost = "host";
inline constexpr const char* kClock = "clock";
inline constexpr const char* kTimeOrigin = "time_origin";
inline constexpr const char* kTheta = "theta";
inline constexpr const char* kSensorGeometryNote = "sensor_geometry_note";
inline constexpr const char* kSummary = "summary";
inline constexpr const char* kRealtime = "realtime";
inline constexpr const char* kStopCause = "stop_cause";
inline constexpr const char* kOutput = "output";
inline constexpr const char* kError = "error";
inline constexpr const char* kObserverModel = "observer_model";
inline constexpr const char* kLinkOutages = "link_outages";
inline constexpr const char* kStreamGapsFetched = "stream_gaps_fetched";
inline constexpr const char* kBoardClockOffset = "board_clock_offset_ns";
inline constexpr const char* kBoardClockRoundTrip = "board_clock_round_trip_ns";
inline constexpr const char* kBoardT0 = "board_t0_ns";
inline constexpr const char* kRig = "rig";
inline constexpr const char* kThetaZero = "theta_zero_m";
inline constexpr const char* kBoardEvents = "board_events";
inline constexpr const char* kRecoveredFrom = "recovered_from";
/// The run's axes: their names in the run's order, comma-separated.
inline constexpr const char* kAxes = "axes";
/// A log written before /axes: the board's axis its one axis was (on a
/// board of several). Read, never written now.
inline constexpr const char* kAxis = "axis";

}  // namespace piezo::host::log_schema
