#pragma once
// What the live view shows of the run under way: the last seconds of the
// drive, the measured angle and the observer's predictions, fed with every
// batch of samples the run logs, plus the latest status. The run's thread
// writes, the web server's threads read.
//
// The window is decimated to min/max columns on a grid fixed in time, so a
// page is sent its window once and then only the columns completed since
// (a few kB/s instead of the whole window four times a second), and what it
// holds is what a fresh snapshot shows. While the run is shorter than the
// window the columns are narrower (halved while the run fits in half of
// them), so a short move shows in detail; each widening resends the window.
// The board's loop histograms go as "histograms" {drive, sensor}, apart from
// the status, when they changed and at most every fourth event. Each axis
// of the run, one or several, sends its series under "axes" ([{name, drive,
// measured, ...}]): a plot per axis; a scan's trigger pulses are a series
// of points, "triggers" (each pulse's edge time and the angle that fired it),
// marked on the angle plot. A pulse that comes after its column was sent
// (the run's summary hands over those the stream lost) makes every page
// take the window again. Once the run has ended (finish), the last columns
// are complete too and the status says how it ended.

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/log_schema.hpp"

namespace piezo::host::view {

/// What one page has been sent: the run it follows and, per series, the
/// first column it has not.
struct LiveCursor {
  std::uint64_t epoch = 0;                     ///< 0: nothing sent yet
  double width = 0.0;                          ///< the columns' width it was sent
  std::vector<std::array<long long, 6>> next;  ///< per axis
  std::uint64_t events = 0;
  std::uint64_t histograms = 0;  ///< the version of the loop histograms it holds
  /// The run's end: not sent yet, in the last event, or written (the
  /// stream asks for the next event only once the last one was written).
  enum class End : std::uint8_t { not_sent, in_last_event, written } end = End::not_sent;
};

class LiveFeed {
 public:
  /// Keeps `window_s` of history in `columns` columns; the drive's zoom
  /// shows the last `zoom_s` at full rate.
  LiveFeed(double window_s, double zoom_s, std::size_t columns = 800)
      : window_s_(window_s), zoom_s_(zoom_s), width_(window_s / static_cast<double>(columns)) {}

  /// Names the run's axes, in the order add() gives their rows (one
  /// unnamed axis until told); a change starts the window again.
  void set_axes(std::vector<std::string> names);
  /// Appends a batch, one LogRows per axis; a batch that starts before the
  /// feed's end is a new run (its clock restarted): the window starts again.
  void add(const log_schema::AxesRows& rows);
  /// The same for a run of one axis.
  void add(const log_schema::LogRows& rows) { add(log_schema::AxesRows{rows}); }
  void set_status(nlohmann::json status);
  /// The run has ended, as `how` says (its status: completed, interrupted,
  /// failed):
  /// no later sample will complete its last columns, so they go as they are.
  void finish(const std::string& how);
  /// Waits until as many pages as `open_pages()` says are open have been
  /// written the run's end, or `timeout` passed; true when they have.
  [[nodiscard]] bool wait_until_pages_have_the_end(const std::function<int()>& open_pages,
                                                   std::chrono::milliseconds timeout) const;

  /// The whole window, the zoom and the status ("reset": true).
  [[nodiscard]] nlohmann::json snapshot() const;
  /// What the page at `cursor` has not seen: the whole window when it has
  /// seen nothing of this run, else the columns completed since, with the
  /// zoom about once a second; always the status, and the board's loop
  /// histograms when they changed, at most about once a second. Advances
  /// the cursor.
  [[nodiscard]] nlohmann::json changes(LiveCursor& cursor) const;

 private:
  struct Column {
    std::vector<double> t, y;
  };
  static constexpr std::size_t kSeries = 6;
  /// drive, measured, observer, open_loop, residual, triggers (kNames'
  /// order); a scan's triggers are points (edge time, the angle that fired it)
  using AxisColumns = std::array<Column, kSeries>;
  [[nodiscard]] nlohmann::json event(LiveCursor& cursor, bool reset) const;
  /// One axis's series (and its zoom when `with_zoom`) into `out`.
  void add_series(nlohmann::json& out, std::size_t axis, LiveCursor& cursor, bool reset,
                  bool with_zoom) const;
  [[nodiscard]] nlohmann::json zoom(const AxisColumns& axis) const;
  [[nodiscard]] double t_end() const;
  [[nodiscard]] double width_now() const;
  void trim(double t_end);
  void restart();

  mutable std::mutex mutex_;
  double window_s_, zoom_s_, width_;
  std::uint64_t epoch_ = 1;
  bool ended_ = false;
  /// Pages written the run's end, and a wait for them (finish's caller's).
  mutable int pages_told_end_ = 0;
  mutable std::condition_variable told_end_;
  std::vector<std::string> names_{""};
  std::vector<AxisColumns> axes_ = std::vector<AxisColumns>(1);
  /// The status without the loop histograms, which go apart (histograms_):
  /// at some 10 KB each they would be most of every event.
  nlohmann::json status_ = nlohmann::json::object();
  nlohmann::json histograms_ = nlohmann::json::object();
  std::uint64_t histograms_version_ = 0;
};

}  // namespace piezo::host::view
