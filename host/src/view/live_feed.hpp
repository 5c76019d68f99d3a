#pragma once
// What the live view shows of the run under way: the last seconds of the
// drive, the measured angle and the observer's predictions, fed with every
// batch of samples the run logs, plus the latest status. The run's thread
// writes, the web server's threads read snapshots.

#include <cstddef>
#include <mutex>
#include <nlohmann/json.hpp>
#include <vector>

#include "log_schema.hpp"

namespace piezo::host::view {

class LiveFeed {
 public:
  /// Keeps `window_s` of history; the drive's zoom shows the last `zoom_s` at full rate.
  LiveFeed(double window_s, double zoom_s) : window_s_(window_s), zoom_s_(zoom_s) {}

  void add(const log_schema::LogRows& rows);
  void set_status(nlohmann::json status);

  /// The window decimated to `columns` columns (min/max), the zoom at full
  /// rate, and the status, as one JSON object.
  [[nodiscard]] nlohmann::json snapshot(std::size_t columns) const;

 private:
  struct Column {
    std::vector<double> t, y;
  };
  void trim(double t_end);

  mutable std::mutex mutex_;
  double window_s_, zoom_s_;
  Column drive_, measured_, observer_, open_loop_, residual_;
  nlohmann::json status_ = nlohmann::json::object();
};

}  // namespace piezo::host::view
