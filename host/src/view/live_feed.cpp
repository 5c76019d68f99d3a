#include "live_feed.hpp"

#include <algorithm>

#include "decimate.hpp"

namespace piezo::host::view {
namespace {

void append(std::vector<double>& to, const std::vector<double>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

nlohmann::json to_json(const Series& s) {
  return {{"t", s.t}, {"y", s.y}};
}

}  // namespace

void LiveFeed::add(const log_schema::LogRows& rows) {
  const std::lock_guard lock(mutex_);
  append(drive_.t, rows.drive.t);
  append(drive_.y, rows.drive.V);
  append(measured_.t, rows.sensor.t);
  append(measured_.y, rows.sensor.theta);
  for (Column* c : {&observer_, &open_loop_, &residual_}) append(c->t, rows.observer.t);
  append(observer_.y, rows.observer.theta_hat);
  append(open_loop_.y, rows.observer.theta_open);
  append(residual_.y, rows.observer.residual);
  const double t_end = drive_.t.empty() ? 0.0 : drive_.t.back();
  trim(t_end);
}

void LiveFeed::trim(double t_end) {
  // Dropped in bulk once twice the window is held: amortised, not per sample.
  for (Column* c : {&drive_, &measured_, &observer_, &open_loop_, &residual_}) {
    if (c->t.empty() || c->t.front() > t_end - 2.0 * window_s_) continue;
    const auto keep = std::lower_bound(c->t.begin(), c->t.end(), t_end - window_s_) - c->t.begin();
    c->t.erase(c->t.begin(), c->t.begin() + keep);
    c->y.erase(c->y.begin(), c->y.begin() + keep);
  }
}

void LiveFeed::set_status(nlohmann::json status) {
  const std::lock_guard lock(mutex_);
  status_ = std::move(status);
}

nlohmann::json LiveFeed::snapshot(std::size_t columns) const {
  const std::lock_guard lock(mutex_);
  const double t_end = drive_.t.empty() ? 0.0 : drive_.t.back();
  const double t0 = std::max(0.0, t_end - window_s_), t1 = std::max(t_end, t0 + 1e-3);
  const auto decimated = [&](const Column& c) {
    return to_json(min_max_decimate(c.t, c.y, t0, t1, columns));
  };
  // The zoom: the last few drive periods, every sample.
  const auto zoom_from = static_cast<std::size_t>(
      std::lower_bound(drive_.t.begin(), drive_.t.end(), t_end - zoom_s_) - drive_.t.begin());
  const Series zoom{{drive_.t.begin() + static_cast<std::ptrdiff_t>(zoom_from), drive_.t.end()},
                    {drive_.y.begin() + static_cast<std::ptrdiff_t>(zoom_from), drive_.y.end()}};
  return {{"t_end", t_end},
          {"window_s", window_s_},
          {"measured", decimated(measured_)},
          {"observer", decimated(observer_)},
          {"open_loop", decimated(open_loop_)},
          {"residual", decimated(residual_)},
          {"drive", decimated(drive_)},
          {"zoom", to_json(zoom)},
          {"status", status_}};
}

}  // namespace piezo::host::view
