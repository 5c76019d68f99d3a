#include "run_recovery.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <utility>

#include "catalogue.hpp"
#include "h5_file.hpp"
#include "log_schema.hpp"
#include "piezo/config/config_error.hpp"
#include "run_journal.hpp"

namespace piezo::host {
namespace fs = std::filesystem;
namespace {

/// Stands for a small code (phase, status, move state) lost in a damaged
/// chunk; a lost float64 value is NaN.
constexpr double kLostCode = 255;

/// What run.h5 gives, dataset by dataset, as far as each can be read.
struct LogCopy {
  bool opened = false;
  bool whole = false;  ///< every dataset read to its claimed length, every group even
  std::string status;  ///< the status attribute, "incomplete" without one
  std::map<std::string, std::string> attributes;
  std::map<std::string, std::vector<double>, std::less<>> columns;  ///< readable prefixes
  std::map<std::string, std::size_t, std::less<>> claimed;          ///< declared lengths
  std::map<std::string, std::vector<double>> timing;                ///< written whole at the end
  std::vector<std::string> problems;
  std::vector<std::string> axes{""};  ///< its "axes" (log_schema::axis_group)
};

const std::vector<double>& column_of(const LogCopy& copy, std::string_view path) {
  static const std::vector<double> kNone;
  const auto it = copy.columns.find(path);
  return it == copy.columns.end() ? kNone : it->second;
}

/// A dataset's path under an axis's group.
std::string in_group(std::string_view group, std::string_view path) {
  return std::string(group) + std::string(path);
}

template <class Rows>
bool group_is_even(const LogCopy& copy, std::string_view group) {
  const auto& sets = log_schema::datasets(static_cast<const Rows*>(nullptr));
  const std::size_t rows = column_of(copy, in_group(group, sets[0].path)).size();
  return std::all_of(sets.begin(), sets.end(), [&](const auto& d) {
    return column_of(copy, in_group(group, d.path)).size() == rows;
  });
}

/// Reads what run.h5 holds; `axes`: the journal's, for a log whose own
/// "axes" attribute cannot be read.
LogCopy read_log_copy(const fs::path& log, const std::vector<std::string>& axes) {
  LogCopy copy;
  copy.axes = axes;
  if (!fs::exists(log)) return copy;
  std::optional<H5File> file;
  try {
    file.emplace(H5File::open(log.string()));
  } catch (const std::exception& e) {
    copy.problems.push_back(fmt::format("run.h5 cannot be opened ({})", e.what()));
    return copy;
  }
  copy.opened = true;
  try {
    for (const std::string& name : file->attribute_names("/")) {
      try {
        copy.attributes[name] = file->attribute("/", name);
      } catch (const std::exception& e) {
        copy.problems.push_back(e.what());
      }
    }
  } catch (const std::exception& e) {
    copy.problems.push_back(e.what());
  }
  const auto status = copy.attributes.find(log_schema::kStatus);
  copy.status = status == copy.attributes.end() ? "incomplete" : status->second;
  if (const auto listed = copy.attributes.find(log_schema::kAxes);
      listed != copy.attributes.end() && !log_schema::split_axes(listed->second).empty()) {
    copy.axes = log_schema::split_axes(listed->second);
  }
  for (std::size_t i = 0; i < copy.axes.size(); ++i) {
    // An axis's own attributes, kept as the journal keeps them: under their path.
    const std::string group = log_schema::axis_group(copy.axes, i);
    if (group.empty() || !file->exists(group)) continue;
    try {
      for (const std::string& name : file->attribute_names(group))
        copy.attributes[group + "/" + name] = file->attribute(group, name);
    } catch (const std::exception& e) {
      copy.problems.push_back(e.what());
    }
  }
  log_schema::AxesRows none(copy.axes.size());
  log_schema::for_each_column(
      none, copy.axes, [&](std::string_view name, const log_schema::Column&) {
        const std::string path(name);
        std::size_t& claimed = copy.claimed[path];
        std::vector<double>& values = copy.columns[path];
        try {
          claimed = file->extent(path);
          values = file->read_prefix(path);
          if (values.size() < claimed) {
            copy.problems.push_back(
                fmt::format("{}: {} of its {} values can be read", path, values.size(), claimed));
          }
        } catch (const std::exception& e) {
          copy.problems.push_back(fmt::format("{}: {}", path, e.what()));
        }
      });
  for (const char* path : {log_schema::kDrivePeriodErrorUs, log_schema::kAcquirePeriodErrorUs}) {
    if (!file->exists(path)) continue;
    try {
      copy.timing[path] = file->read(path);
    } catch (const std::exception& e) {
      copy.problems.push_back(fmt::format("{}: {}", path, e.what()));
    }
  }
  // A generic reader walks every group: a damaged one fails it even where
  // each dataset, opened by its path, reads.
  if (std::string unreachable = file->unreachable_objects(); !unreachable.empty()) {
    copy.problems.push_back(std::move(unreachable));
  }
  bool even = true;
  for (std::size_t i = 0; i < copy.axes.size(); ++i) {
    const std::string group = log_schema::axis_group(copy.axes, i);
    even = even && group_is_even<log_schema::DriveRows>(copy, group) &&
           group_is_even<log_schema::SensorRows>(copy, group) &&
           group_is_even<log_schema::ObserverRows>(copy, group);
  }
  if (!even) copy.problems.emplace_back("its datasets of one group differ in length");
  copy.whole = copy.problems.empty();
  return copy;
}

/// One group (drive, sensor, observer or a scan's triggers) merged from both copies into
/// `into`: row by row, the journal's value where it holds the row (each
/// block CRC-checked and written before run.h5's copy; HDF5 killed inside a
/// flush can leave an extent whose chunk was never written, read back as
/// fill values without an error), else run.h5's, else lost. A journal of
/// another run (`same_run` false) is never mixed in: the longer copy is
/// used alone. Returns the rows kept; adds to `losses`.
template <class Rows>
std::size_t merge_group(const LogCopy& log, const Rows& journal, bool same_run, Rows& into,
                        std::string_view prefix, std::string_view group,
                        std::vector<std::string>& losses) {
  const auto& sets = log_schema::datasets(static_cast<const Rows*>(nullptr));
  const std::size_t log_rows = column_of(log, in_group(prefix, sets[0].path)).size();
  const std::size_t journal_rows = (journal.*sets[0].column).size();
  const bool use_log = same_run || log_rows >= journal_rows;
  const bool use_journal = same_run || !use_log;
  const std::size_t rows = std::max(use_log ? log_rows : 0, use_journal ? journal_rows : 0);
  std::size_t found = journal_rows;
  for (const auto& d : sets) {
    const std::string path = in_group(prefix, d.path);
    const auto claimed = log.claimed.find(path);
    if (claimed != log.claimed.end()) found = std::max(found, claimed->second);
    const std::vector<double>& from_log = column_of(log, path);
    const std::vector<double>& from_journal = journal.*d.column;
    log_schema::Column& out = into.*d.column;
    out.resize(rows);
    std::size_t lost = 0;
    for (std::size_t i = 0; i < rows; ++i) {
      if (use_journal && i < from_journal.size()) {
        out[i] = from_journal[i];
      } else if (use_log && i < from_log.size()) {
        out[i] = from_log[i];
      } else {
        out[i] = d.storage == log_schema::Storage::uint8 ? kLostCode : std::nan("");
        ++lost;
      }
    }
    if (lost > 0) {
      losses.push_back(fmt::format("{}: {} of {} values lost in damaged chunks (written as {})",
                                   path, lost, rows,
                                   d.storage == log_schema::Storage::uint8 ? "255" : "NaN"));
    }
  }
  if (rows < found) {
    losses.push_back(
        fmt::format("{}{}: kept {} of the {} rows a copy claimed", prefix, group, rows, found));
  }
  return rows;
}

/// Whether the journal was written beside this very run.h5: the header both
/// copies were started with agrees wherever both can be read. (Sample values
/// cannot tell: the last rows of a killed log are the ones likely to read
/// back as fill values.)
bool same_run(const LogCopy& log, const JournalContents& journal) {
  for (const char* key : {log_schema::kUtcStart, log_schema::kHost, log_schema::kConfig}) {
    const auto in_log = log.attributes.find(key);
    const auto in_journal = journal.header.find(key);
    if (in_log != log.attributes.end() && in_journal != journal.header.end() &&
        in_log->second != in_journal->second) {
      return false;
    }
  }
  return true;
}

template <class Rows>
bool journal_has_more(const LogCopy& log, const Rows& journal, std::string_view group) {
  const auto& sets = log_schema::datasets(static_cast<const Rows*>(nullptr));
  return (journal.*sets[0].column).size() > column_of(log, in_group(group, sets[0].path)).size();
}

/// True when a running `piezo run` still holds the journal.
bool in_use(const fs::path& journal) {
  const int fd = ::open(journal.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = flock(fd, LOCK_EX | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

double last_finite(const log_schema::Column& c) {
  for (auto it = c.rbegin(); it != c.rend(); ++it)
    if (std::isfinite(*it)) return *it;
  return std::nan("");
}

void write_log(const fs::path& out, log_schema::AxesRows& rows,
               const std::vector<std::string>& axes,
               const std::map<std::string, std::string>& attributes, const LogCopy& log) {
  H5File f = H5File::create_log(out.string());
  log_schema::for_each_column(rows, axes, [&](std::string_view name, log_schema::Column& c) {
    const std::string path(name);
    f.create_growing(path, log_schema::storage(name) == log_schema::Storage::uint8);
    f.append(path, c);
  });
  for (const auto& [path, values] : log.timing) f.write(path, values);
  for (const auto& [key, value] : attributes) {
    // An axis's attribute is kept under its path ("/axes/theta/summary").
    const std::size_t slash = key.rfind('/');
    if (key.starts_with('/') && slash > 0 && f.exists(key.substr(0, slash))) {
      f.set_attribute(key.substr(0, slash), key.substr(slash + 1), value);
    } else {
      f.set_attribute("/", key, value);
    }
  }
  f.close();
}

void add_to_catalogue(const fs::path& dir, const std::map<std::string, std::string>& attributes,
                      const std::vector<std::string>& axes, const log_schema::AxesRows& rows) {
  const auto get = [&](const char* key) {
    const auto it = attributes.find(key);
    return it == attributes.end() ? std::string() : it->second;
  };
  CatalogueEntry entry{.utc_start = get(log_schema::kUtcStart),
                       .status = "recovered",
                       .stop_cause = "unknown",
                       .config = get(log_schema::kConfigSource),
                       .t_end_s = last_finite(rows.front().drive.t),
                       .axes = {}};
  for (std::size_t i = 0; i < axes.size(); ++i) {
    entry.axes.push_back({axes[i], last_finite(rows[i].sensor.theta)});
  }
  append_to_catalogue(dir, entry);
}

}  // namespace

Recovery recover_run(const std::string& run_dir) {
  const fs::path dir(run_dir), log = dir / "run.h5", journal = dir / "run.journal";
  Recovery r;
  const bool has_journal = fs::exists(journal);
  if (has_journal && in_use(journal)) {
    throw config::ConfigError(run_dir, "run.journal",
                              "still held by a running piezo run; recover after it ends");
  }
  JournalContents j;
  if (has_journal) j = read_journal(journal.string());
  const LogCopy copy = read_log_copy(log, j.axes);
  if (!has_journal && !copy.opened) {
    throw config::ConfigError(run_dir, fs::exists(log) ? "run.h5" : "run.journal",
                              fs::exists(log) ? "unreadable, and no run.journal to rebuild it from"
                                              : "no run log or journal in this directory");
  }
  if (!has_journal || j.header.empty()) {
    // No journal, or one torn inside its header (nothing of it readable):
    // nothing to add to any axis of the log.
    j.axes = copy.axes;
    j.rows.assign(copy.axes.size(), log_schema::LogRows{});
  }
  if (j.axes != copy.axes) {
    throw config::ConfigError(run_dir, "run.journal",
                              fmt::format("names the axes \"{}\", run.h5 \"{}\": not one run's",
                                          fmt::join(j.axes, ","), fmt::join(copy.axes, ",")));
  }
  bool journal_adds = false;
  for (std::size_t i = 0; i < copy.axes.size(); ++i) {
    const std::string group = log_schema::axis_group(copy.axes, i);
    journal_adds = journal_adds || journal_has_more(copy, j.rows[i].drive, group) ||
                   journal_has_more(copy, j.rows[i].sensor, group) ||
                   journal_has_more(copy, j.rows[i].observer, group) ||
                   journal_has_more(copy, j.rows[i].triggers, group);
  }
  // Whole and final (or whole, still "incomplete", with no journal to add
  // to it: readable up to its last flush): nothing to do.
  if (copy.whole && !journal_adds && (copy.status != "incomplete" || !has_journal)) {
    if (has_journal) fs::remove(journal);
    r.status = copy.status;
    return r;
  }

  log_schema::AxesRows rows(copy.axes.size());
  const bool one_run = same_run(copy, j);
  for (std::size_t i = 0; i < copy.axes.size(); ++i) {
    const std::string group = log_schema::axis_group(copy.axes, i);
    const auto& from = j.rows[i];
    r.drive_rows += merge_group(copy, from.drive, one_run, rows[i].drive, group, "drive", r.losses);
    r.sensor_rows +=
        merge_group(copy, from.sensor, one_run, rows[i].sensor, group, "sensor", r.losses);
    r.observer_rows +=
        merge_group(copy, from.observer, one_run, rows[i].observer, group, "observer", r.losses);
    r.trigger_rows +=
        merge_group(copy, from.triggers, one_run, rows[i].triggers, group, "triggers", r.losses);
  }
  r.blocks = j.blocks;
  r.torn_bytes = j.torn_bytes;
  // The journal's attributes first; run.h5's, where readable, are as new.
  std::map<std::string, std::string> attributes = j.header;
  for (const auto& [key, value] : j.attributes) attributes[key] = value;
  for (const auto& [key, value] : copy.attributes) attributes[key] = value;
  attributes[log_schema::kStatus] = "recovered";
  std::string from = has_journal ? fmt::format("run.journal: {} blocks, {} torn bytes at its end",
                                               j.blocks, j.torn_bytes)
                                 : std::string("no run.journal");
  from += copy.opened ? "; run.h5: its readable rows" : "; run.h5: none (unreadable or missing)";
  for (const std::string& p : copy.problems) from += "; run.h5 " + p;
  attributes["recovered_from"] = from;
  if (r.kept_less()) {
    std::string all;
    for (const std::string& loss : r.losses) all += (all.empty() ? "" : "; ") + loss;
    attributes["recovery_losses"] = all;
  }

  // Written aside and renamed: a crash during recovery leaves both copies.
  const fs::path fresh = dir / "run.h5.recovering";
  write_log(fresh, rows, copy.axes, attributes, copy);
  if (fs::exists(log)) {
    r.damaged = (dir / "run.h5.damaged").string();
    fs::rename(log, r.damaged);
  }
  fs::rename(fresh, log);
  if (has_journal) fs::remove(journal);
  r.rebuilt = true;
  r.status = "recovered";
  add_to_catalogue(dir, attributes, copy.axes, rows);
  return r;
}

void recover_if_needed(const std::string& log_path) {
  const fs::path log(log_path);
  const fs::path journal = fs::path(journal_path(log_path));
  if (!fs::exists(journal) || in_use(journal)) return;
  const Recovery r = recover_run(log.parent_path().string());
  if (!r.rebuilt) return;
  std::fputs(fmt::format("{}: rebuilt from run.h5 and run.journal ({} drive, {} sensor samples), "
                         "marked recovered\n",
                         log_path, r.drive_rows, r.sensor_rows)
                 .c_str(),
             stderr);
  for (const std::string& loss : r.losses) {
    std::fputs(fmt::format("{}: not recovered: {}\n", log_path, loss).c_str(), stderr);
  }
}

}  // namespace piezo::host
