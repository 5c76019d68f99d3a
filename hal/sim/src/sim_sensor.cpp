#include "piezo/hal/sim/sim_sensor.hpp"

#include <cmath>

namespace piezo::hal::sim {

SimSensor::SimSensor(const SimSensorSettings& settings, const Plant& plant, Clock& clock, TimeNs t0)
    : settings_(settings),
      plant_(plant),
      clock_(clock),
      t0_(t0),
      random_(settings.seed),
      noise_(0.0, settings.noise_m) {}

void SimSensor::set_time_origin(TimeNs t0) {
  t0_ = t0;
  random_.seed(settings_.seed);
  noise_.reset();
  uniform_.reset();
  blind_theta_ = std::numeric_limits<double>::quiet_NaN();
}

bool SimSensor::stalled(TimeNs t) const {
  const double since_start = to_seconds(t - t0_);
  return since_start >= settings_.stall_at_s &&
         since_start < settings_.stall_at_s + settings_.stall_for_s;
}

DisplacementReading SimSensor::read() {
  DisplacementReading r;
  r.t_request = clock_.now();
  if (stalled(r.t_request)) {
    clock_.sleep_until(r.t_request + from_seconds(settings_.timeout_s));
    r.t_response = clock_.now();
    r.status = Status::timeout;
    return r;
  }
  // The plant was last advanced at a drive write; carry it to the request time.
  const PlantSnapshot snap = plant_.latest();
  double theta = snap.theta + snap.theta_dot * to_seconds(r.t_request - snap.t);
  const double since_start = to_seconds(r.t_request - t0_);
  if (since_start >= settings_.blind_at_s) {
    if (std::isnan(blind_theta_)) blind_theta_ = theta;
    theta = blind_theta_;
  }
  double d = settings_.offset_m + settings_.r2_m * theta;
  if (settings_.noise_m > 0.0) d += noise_(random_);
  if (settings_.quantum_m > 0.0) d = std::round(d / settings_.quantum_m) * settings_.quantum_m;
  if (since_start >= settings_.freeze_at_s && !std::isnan(frozen_m_)) d = frozen_m_;
  r.displacement_m = frozen_m_ = d;
  if (settings_.dropout_probability > 0.0 && uniform_(random_) < settings_.dropout_probability) {
    r.status = Status::invalid_reading;
  }
  clock_.sleep_until(r.t_request + from_seconds(settings_.latency_s));
  r.t_response = clock_.now();
  return r;
}

}  // namespace piezo::hal::sim
