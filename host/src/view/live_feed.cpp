#include "live_feed.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "decimate.hpp"
#include "piezo/firmware/wire_keys.hpp"

namespace piezo::host::view {
namespace {

constexpr std::array<std::string_view, 6> kNames{wire_key::drive, "measured", "observer",
                                                 "open_loop",     "residual", wire_key::triggers};
enum : std::size_t { kDrive, kMeasured, kObserver, kOpenLoop, kResidual, kTriggers };
/// The zoom (thousands of full-rate samples) and changed loop histograms go
/// with every fourth event: about once a second, which is most of what a
/// viewer costs.
constexpr std::uint64_t kZoomEvery = 4;

/// Removes the loop histograms (`histogram_us`) from a status's board
/// health and its summary; returns the health's, by loop.
nlohmann::json take_histograms(nlohmann::json& status) {
  nlohmann::json taken = nlohmann::json::object();
  auto board = status.find(wire_key::board);
  if (board == status.end() || !board->is_object()) return taken;
  for (const std::string_view loop : {wire_key::drive, wire_key::sensor}) {
    auto health = board->find(loop);
    if (health != board->end() && health->is_object() && health->contains(wire_key::histogram_us)) {
      taken[loop] = std::move((*health)[wire_key::histogram_us]);
      health->erase(wire_key::histogram_us);
    }
    auto summary = board->find(wire_key::summary);
    if (summary != board->end() && summary->is_object() && summary->contains(loop) &&
        (*summary)[loop].is_object()) {
      (*summary)[loop].erase(wire_key::histogram_us);
    }
  }
  return taken;
}

void append(std::vector<double>& to, const std::vector<double>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

/// Points into a series in time order: a scan's pulses come as fired, and
/// those the stream lost at the run's end.
void insert_points(std::vector<double>& t, std::vector<double>& y, const std::vector<double>& at,
                   const std::vector<double>& values) {
  for (std::size_t i = 0; i < at.size() && i < values.size(); ++i) {
    const auto where = std::upper_bound(t.begin(), t.end(), at[i]) - t.begin();
    t.insert(t.begin() + where, at[i]);
    y.insert(y.begin() + where, values[i]);
  }
}

/// Numbers as short as what they show: times to the microsecond, values to
/// seven significant digits (JSON prints the shortest form that reads back).
double short_time(double t) {
  return std::round(t * 1e6) / 1e6;
}
double short_value(double v) {
  if (!std::isfinite(v) || v == 0.0) return v;
  const double scale = std::pow(10.0, 6 - static_cast<int>(std::floor(std::log10(std::abs(v)))));
  return std::round(v * scale) / scale;
}

nlohmann::json to_json(const Series& s) {
  nlohmann::json t = nlohmann::json::array(), y = nlohmann::json::array();
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    t.push_back(short_time(s.t[i]));
    y.push_back(short_value(s.y[i]));
  }
  return {{"t", std::move(t)}, {"y", std::move(y)}};
}

}  // namespace

void LiveFeed::set_axes(std::vector<std::string> names) {
  const std::lock_guard lock(mutex_);
  if (names.empty()) names = {""};
  if (names == names_) return;
  names_ = std::move(names);
  restart();
}

void LiveFeed::add(const log_schema::AxesRows& rows) {
  const std::lock_guard lock(mutex_);
  // A batch of another count of axes, or one whose drive starts before
  // its axis's last: a new run (its clock restarted). Each axis against its
  // own: a batch may end between two axes' records of one tick.
  bool restarted = rows.size() != axes_.size();
  for (std::size_t i = 0; i < rows.size() && !restarted; ++i) {
    const Column& drive = axes_[i][kDrive];
    restarted =
        !rows[i].drive.t.empty() && !drive.t.empty() && rows[i].drive.t.front() < drive.t.back();
  }
  if (restarted) {
    if (rows.size() != axes_.size()) {
      names_.assign(rows.size(), "");
      axes_.assign(rows.size(), AxisColumns{});
    }
    restart();
  }
  // Pages may hold every column before the one the drive's end is in.
  const double width = width_now(),
               sent_until = static_cast<double>(column_of(t_end(), width)) * width;
  bool late_pulse = false;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const log_schema::LogRows& r = rows[i];
    AxisColumns& c = axes_[i];
    append(c[kDrive].t, r.drive.t);
    append(c[kDrive].y, r.drive.V);
    append(c[kMeasured].t, r.sensor.t);
    append(c[kMeasured].y, r.sensor.theta);
    for (std::size_t s : {kObserver, kOpenLoop, kResidual}) append(c[s].t, r.observer.t);
    append(c[kObserver].y, r.observer.theta_hat);
    append(c[kOpenLoop].y, r.observer.theta_open);
    append(c[kResidual].y, r.observer.residual);
    insert_points(c[kTriggers].t, c[kTriggers].y, r.triggers.edge_s, r.triggers.angle_rad);
    late_pulse = late_pulse || std::any_of(r.triggers.edge_s.begin(), r.triggers.edge_s.end(),
                                           [&](double edge) { return edge < sent_until; });
  }
  trim(t_end());
  if (late_pulse) ++epoch_;  // its column went without it: every page takes the window again
}

void LiveFeed::restart() {
  axes_.assign(names_.size(), AxisColumns{});
  ended_ = false;
  ++epoch_;
}

void LiveFeed::finish(const std::string& how) {
  const std::lock_guard lock(mutex_);
  ended_ = true;
  status_["ended"] = how;
}

bool LiveFeed::wait_until_pages_have_the_end(const std::function<int()>& open_pages,
                                             std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return told_end_.wait_for(lock, timeout, [&] { return pages_told_end_ >= open_pages(); });
}

double LiveFeed::t_end() const {
  // The latest drive sample of any axis: a group's axes end each on its own.
  double end = 0.0;
  for (const AxisColumns& c : axes_)
    if (!c[kDrive].t.empty()) end = std::max(end, c[kDrive].t.back());
  return end;
}

void LiveFeed::trim(double t_end) {
  // Dropped in bulk once twice the window is held: amortised, not per sample.
  for (AxisColumns& axis : axes_) {
    for (Column& c : axis) {
      if (c.t.empty() || c.t.front() > t_end - 2.0 * window_s_) continue;
      const auto keep = std::lower_bound(c.t.begin(), c.t.end(), t_end - window_s_) - c.t.begin();
      c.t.erase(c.t.begin(), c.t.begin() + keep);
      c.y.erase(c.y.begin(), c.y.begin() + keep);
    }
  }
}

void LiveFeed::set_status(nlohmann::json status) {
  nlohmann::json histograms = take_histograms(status);
  const std::lock_guard lock(mutex_);
  status_ = std::move(status);
  if (!histograms.empty() && histograms != histograms_) {
    histograms_ = std::move(histograms);
    ++histograms_version_;
  }
}

nlohmann::json LiveFeed::snapshot() const {
  const std::lock_guard lock(mutex_);
  LiveCursor cursor;
  return event(cursor, true);
}

nlohmann::json LiveFeed::changes(LiveCursor& cursor) const {
  const std::lock_guard lock(mutex_);
  nlohmann::json out = event(cursor, cursor.epoch != epoch_ || cursor.width != width_now());
  using End = LiveCursor::End;
  if (cursor.end == End::in_last_event) {
    cursor.end = End::written;
    ++pages_told_end_;
    told_end_.notify_all();
  }
  if (ended_ && cursor.end == End::not_sent) cursor.end = End::in_last_event;
  return out;
}

double LiveFeed::width_now() const {
  const double columns = window_s_ / width_, end = t_end();
  double w = width_;
  while (w > width_ / 1024 && end <= columns * w / 2) w /= 2;
  return w;
}

void LiveFeed::add_series(nlohmann::json& out, std::size_t axis, LiveCursor& cursor, bool reset,
                          bool with_zoom) const {
  const double end = t_end(), width = width_now();
  // The window's first whole column, and per series its last complete one:
  // a column is complete once a later sample has come.
  const long long window_start = column_of(end - window_s_, width) + 1;
  for (std::size_t s = 0; s < kSeries; ++s) {
    const Column& c = axes_[axis][s];
    // A column is complete once a later sample came; the sparse triggers'
    // once the drive has passed it (a pulse is published before the
    // samples of its time); every one once the run has ended.
    const long long last = s == kTriggers ? column_of(end, width)
                           : c.t.empty()  ? window_start
                                          : column_of(c.t.back(), width);
    const long long done = ended_ ? last + 1 : last;
    const long long from = reset ? window_start : std::max(cursor.next[axis][s], window_start);
    out[kNames[s]] = to_json(min_max_columns(c.t, c.y, width, from, done));
    cursor.next[axis][s] = std::max(from, done);
  }
  if (with_zoom) out["zoom"] = zoom(axes_[axis]);
}

nlohmann::json LiveFeed::event(LiveCursor& cursor, bool reset) const {
  const double end = t_end(), width = width_now();
  nlohmann::json out{
      {"reset", reset}, {"t_end", short_time(end)}, {"window_s", window_s_}, {"column_s", width}};
  if (cursor.next.size() != axes_.size()) {
    cursor.next.assign(axes_.size(), {});
    reset = true;
    out["reset"] = true;
  }
  const bool with_zoom = reset || cursor.events % kZoomEvery == 0;
  nlohmann::json axes = nlohmann::json::array();
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    nlohmann::json axis{{wire_key::name, names_[i]}};
    add_series(axis, i, cursor, reset, with_zoom);
    axes.push_back(std::move(axis));
  }
  out[wire_key::axes] = std::move(axes);
  out["status"] = status_;
  if (cursor.histograms != histograms_version_ && with_zoom) {
    out["histograms"] = histograms_;
    cursor.histograms = histograms_version_;
  }
  cursor.epoch = epoch_;
  cursor.width = width;
  ++cursor.events;
  return out;
}

nlohmann::json LiveFeed::zoom(const AxisColumns& axis) const {
  // The last few drive periods, every sample. The drive's clock is a grid:
  // its times go as a start and a step when they are (they are, unless a
  // missed cycle left a gap).
  const Column& d = axis[kDrive];
  const auto from = static_cast<std::size_t>(
      std::lower_bound(d.t.begin(), d.t.end(), (d.t.empty() ? 0.0 : d.t.back()) - zoom_s_) -
      d.t.begin());
  const std::size_t n = d.t.size() - from;
  nlohmann::json y = nlohmann::json::array();
  for (std::size_t i = from; i < d.t.size(); ++i) y.push_back(short_value(d.y[i]));
  const double t0 = n > 0 ? d.t[from] : 0.0;
  const double dt = n > 1 ? (d.t.back() - t0) / static_cast<double>(n - 1) : 0.0;
  bool grid = n > 1;
  for (std::size_t i = from; i < d.t.size() && grid; ++i) {
    grid = std::abs(d.t[i] - (t0 + static_cast<double>(i - from) * dt)) < 0.01 * dt;
  }
  if (grid) return {{"t0", t0}, {"dt", dt}, {"y", std::move(y)}};
  nlohmann::json t = nlohmann::json::array();
  for (std::size_t i = from; i < d.t.size(); ++i) t.push_back(short_time(d.t[i]));
  return {{"t", std::move(t)}, {"y", std::move(y)}};
}

}  // namespace piezo::host::view
