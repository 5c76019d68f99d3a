// The axes between runs: the idle reader's readings become each axis's
// position, noise and age at rest, and a rotor that moves at rest is
// reported (docs/protocol.md, "At rest").

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <zmq_addon.hpp>

#include "daemon.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/topics.hpp"

namespace piezo::daemon {
namespace {

/// Idle periods without a good reading after which an axis's sensor is
/// said not to answer (`rest.stale`).
constexpr double kStaleIdlePeriods = 5.0;

}  // namespace
void Daemon::begin_rest() {
  for (const auto& axis : axes_) {
    axis->rest.begin();
    axis->rest_errors = 0;
  }
}

void Daemon::advance_simulated_rig() {
  if (rig_.sim) rig_.sim->advance_to(rig_.clock->now());
}

void Daemon::take_idle_readings() {
  if (!idle_) return;
  IdleReading r;
  // A run's loops own the sensors; what the reader took before the run's
  // hold is of the rest that ended.
  while (idle_->next(r)) {
    if (running()) continue;
    ServedAxis& axis = *axes_.at(r.axis);
    axis.last_idle_failed = r.status != hal::Status::ok || !std::isfinite(r.displacement_m);
    if (axis.last_idle_failed) {
      ++axis.rest_errors;
      continue;
    }
    axis.remember_reading(r.displacement_m);
    axis.last_good_wall_ns = r.wall_ns;
    const auto move = axis.rest.add(r.displacement_m);
    // No zero yet: the rest's reference (a mean at rest) is the zero.
    if (!axis.zero.known() && axis.rest.reference_m()) {
      axis.zero.set(*axis.rest.reference_m());
      log_event(
          fmt::format("axis {}: zero set at {:.9g} m (the mean of its first {} readings "
                      "at rest)",
                      axis.name(), *axis.rest.reference_m(), firmware::RestWatch::kMean));
    }
    if (!move) continue;
    const double r2 = axis.config.sensor.r2_m;
    protocol::MovedEvent e;
    e.board_id = board_id_;
    e.board_ns = rig_.clock->now();
    e.axis = axis.name();
    e.moved_m = move->moved_m;
    e.moved_rad = move->moved_m / r2;
    e.rest = rest_of(axis);
    log_event(
        fmt::format("axis {}: moved at rest by {:.6g} rad ({:.4g} um at the sensor; "
                    "{:.6g} rad since its rest began)",
                    axis.name(), e.moved_rad, move->moved_m * 1e6, move->since_rest_m / r2));
    const std::string body = protocol::encode_map(e);
    std::array<zmq::const_buffer, 2> parts{zmq::buffer(protocol::topic::moved), zmq::buffer(body)};
    (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
  }
}

protocol::RestReport Daemon::rest_of(const ServedAxis& axis) const {
  protocol::RestReport r;
  const double r2 = axis.config.sensor.r2_m;
  r.name = axis.name();
  r.position_rad = position_of(axis).position_rad;
  r.noise_m = axis.rest.noise_m();
  if (r.noise_m) r.noise_rad = *r.noise_m / r2;
  if (axis.last_good_wall_ns != 0)
    r.age_s = 1e-9 * static_cast<double>(steady_ns() - axis.last_good_wall_ns);
  r.moved_rad = axis.rest.since_rest_m() / r2;
  r.moved = axis.rest.moved();
  r.errors = axis.rest_errors;
  // Between runs, with the idle reader on: a sensor that does not answer.
  // (During a run its own readings, or none for an axis the run leaves
  // alone, as for the board's start before its first reading.)
  if (!running() && idle_ && idle_->rate_hz() > 0.0) {
    const double stale_after_s = std::max(1.0, kStaleIdlePeriods / idle_->rate_hz());
    r.stale = axis.last_idle_failed || !r.age_s || *r.age_s > stale_after_s;
  }
  return r;
}

}  // namespace piezo::daemon
