#include "piezo/hal/sim/plant.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::hal::sim {

Plant::Plant(const model::MotorParameters& motor, const AmplifierSettings& amplifier, TimeNs t0,
             double end_stop_rad)
    : amplifier_(amplifier), motor_(motor), rhs_(motor), t_(t0), end_stop_rad_(end_stop_rad) {
  motor_.reset(to_seconds(t0), model::LuGreState{});
  publish();
}

double Plant::output_target() const {
  if (!enabled_) return 0.0;
  return std::clamp(amplifier_.gain * V_in_, amplifier_.V_out_min, amplifier_.V_out_max);
}

void Plant::advance_to(TimeNs t) {
  if (t <= t_) return;
  // The output ramps until ramp_end_, then holds its target.
  const double t0 = to_seconds(t_), t1 = to_seconds(t);
  const TimeNs ramp_stop = std::min(t, std::max(ramp_end_, t_));
  const double t_ramp = to_seconds(ramp_stop);
  if (ramp_stop > t_) {
    motor_.advance({t0, stator_V(), slope_}, t_ramp);
    V_out_ += slope_ * (t_ramp - t0);
    hold_at_end_stop();
  }
  if (t > ramp_stop) {
    // A held input: integrated slice by slice while the motor moves; once
    // it is at rest the rest of the gap is skipped, since nothing changes.
    // (Integrated whole at the stator's step, 30 s of idle once held the
    // drive thread 1.8 s on the next run's first write.)
    V_out_ = output_target();
    constexpr TimeNs kSlice = 5'000'000;
    for (TimeNs from = ramp_stop; from < t;) {
      if (at_rest()) {
        motor_.reset(t1, motor_.state());
        break;
      }
      const TimeNs to = std::min(t, from + kSlice);
      motor_.advance({to_seconds(from), stator_V(), 0.0}, to_seconds(to));
      hold_at_end_stop();
      from = to;
    }
  }
  t_ = t;
}

void Plant::hold_at_end_stop() {
  // Checked at each advance (a drive period, 0.1 ms at 10 kHz): an
  // inelastic stop, the rotor's velocity lost against it.
  if (std::isnan(end_stop_rad_)) return;
  model::LuGreState y = motor_.state();
  const double beyond = (y[model::kTheta] - end_stop_rad_) * (end_stop_rad_ >= 0.0 ? 1.0 : -1.0);
  if (beyond < 0.0) return;
  y[model::kTheta] = end_stop_rad_;
  y[model::kThetaDot] = 0.0;
  motor_.reset(motor_.time(), y);
}

bool Plant::at_rest() const {
  // Still, and not about to move: velocities and accelerations far below
  // anything the sensor resolves over any gap (a velocity alone could be a
  // zero crossing of a ringing stator).
  const model::LuGreState& y = motor_.state();
  model::LuGreState dydt{};
  rhs_.derivative(stator_V(), y, dydt);
  return std::abs(y[model::kXDot]) <= 1e-9 && std::abs(y[model::kThetaDot]) <= 1e-9 &&
         std::abs(dydt[model::kXDot]) <= 1e-6 && std::abs(dydt[model::kThetaDot]) <= 1e-6;
}

void Plant::start_ramp() {
  const double gap = output_target() - V_out_;
  const double wanted = amplifier_.ramp_time_s > 0.0 ? gap / amplifier_.ramp_time_s
                                                     : std::copysign(amplifier_.slew_V_per_s, gap);
  slope_ = std::clamp(wanted, -amplifier_.slew_V_per_s, amplifier_.slew_V_per_s);
  ramp_end_ = slope_ == 0.0 ? t_ : t_ + from_seconds(gap / slope_);
}

void Plant::trip(TimeNs t) {
  TimeNs expected = kNoTrip;
  trip_at_.compare_exchange_strong(expected, t);
  published_enabled_.store(false);
}

void Plant::take_trip() {
  const TimeNs at = trip_at_.exchange(kNoTrip);
  if (at == kNoTrip) return;
  advance_to(std::max(at, t_));
  enabled_ = false;
  start_ramp();
  publish();
}

void Plant::set_input(TimeNs t, double V_in) {
  take_trip();
  advance_to(t);
  V_in_ = V_in;
  start_ramp();
  publish();
  notify_neighbours();
}

void Plant::advance(TimeNs t) {
  take_trip();
  advance_to(std::max(t, t_));
  publish();
}

void Plant::turn_by(TimeNs t, double delta_rad) {
  take_trip();
  advance_to(t);
  model::LuGreState y = motor_.state();
  y[model::kTheta] += delta_rad;
  motor_.reset(motor_.time(), y);
  hold_at_end_stop();
  publish();
}

void Plant::set_enabled(TimeNs t, bool enabled) {
  take_trip();
  advance_to(t);
  enabled_ = enabled;
  published_enabled_.store(enabled);
  start_ramp();
  publish();
  notify_neighbours();
}

void Plant::couple_to(Plant& neighbour, double coupling) {
  neighbours_.push_back(&neighbour);
  neighbour.sources_.push_back({this, coupling});
}

void Plant::notify_neighbours() {
  for (Plant* n : neighbours_) n->update_coupled(t_);
}

void Plant::update_coupled(TimeNs t) {
  // The sources' output targets, not their ramps: a neighbour's amplifier
  // reaches its target within its slew time, far shorter than a drive
  // period's edges.
  double V = 0.0;
  for (const Coupling& c : sources_) V += c.coupling * c.source->output_target();
  if (V == coupled_V_) return;
  take_trip();
  advance_to(t);
  coupled_V_ = V;
  publish();
}

void Plant::publish() {
  // Seqlock without fences (the thread sanitizer cannot follow fences): the
  // count turns odd first; each field store is a release, so a reader that
  // sees a new field also sees the odd count afterwards and retries.
  const std::uint64_t s = sequence_.load(std::memory_order_relaxed);
  sequence_.store(s + 1, std::memory_order_relaxed);
  published_t_.store(t_, std::memory_order_release);
  published_theta_.store(motor_.state()[model::kTheta], std::memory_order_release);
  published_theta_dot_.store(motor_.state()[model::kThetaDot], std::memory_order_release);
  published_V_out_.store(V_out_, std::memory_order_release);
  sequence_.store(s + 2, std::memory_order_release);
}

PlantSnapshot Plant::latest() const {
  for (;;) {
    const std::uint64_t before = sequence_.load(std::memory_order_acquire);
    PlantSnapshot snap{published_t_.load(std::memory_order_acquire),
                       published_theta_.load(std::memory_order_acquire),
                       published_theta_dot_.load(std::memory_order_acquire),
                       published_V_out_.load(std::memory_order_acquire)};
    if ((before & 1U) == 0 && sequence_.load(std::memory_order_relaxed) == before) return snap;
  }
}

}  // namespace piezo::hal::sim
