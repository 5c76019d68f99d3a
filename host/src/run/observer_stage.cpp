#include "observer_stage.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace piezo::host {

ObserverStage::ObserverStage(const model::MotorParameters& model, const model::ObserverGains& gains,
                             double ramp_time, double latency)
    : corrected_(model, gains, ramp_time),
      open_loop_(model, {0.0, 0.0}, ramp_time),
      latency_(latency),
      gate_rad_(gains.gate_rad) {}

void ObserverStage::feed_commands_until(double t) {
  while (!pending_commands_.empty() && pending_commands_.front().first <= t) {
    const auto [t_cmd, V] = pending_commands_.front();
    corrected_.command(t_cmd, V);
    open_loop_.command(t_cmd, V);
    last_V_ = V;
    pending_commands_.pop_front();
  }
}

void ObserverStage::process_measurements_until(double t, log_schema::ObserverRows& out) {
  while (!pending_measurements_.empty() && pending_measurements_.front().first <= t) {
    const auto [t_meas, theta] = pending_measurements_.front();
    pending_measurements_.pop_front();
    process(t_meas, theta, out);
  }
}

void ObserverStage::on_drive(double t, double V, log_schema::ObserverRows& out) {
  pending_commands_.emplace_back(t + latency_, V);
  drive_known_until_ = std::max(drive_known_until_, t + latency_);
  process_measurements_until(t, out);
}

void ObserverStage::on_measurement(double t, double theta, log_schema::ObserverRows& out) {
  pending_measurements_.emplace_back(t, theta);
  process_measurements_until(drive_known_until_, out);
}

void ObserverStage::finish(log_schema::ObserverRows& out) {
  process_measurements_until(std::numeric_limits<double>::infinity(), out);
}

void ObserverStage::process(double t, double theta, log_schema::ObserverRows& out) {
  if (t < corrected_.time()) return;  // before the model's start: nothing to compare
  feed_commands_until(t);
  corrected_.advance_to(t);
  open_loop_.advance_to(t);
  double residual = theta - corrected_.state()[model::kTheta];
  if (!(std::abs(residual) <= gate_rad_)) {
    // Gated: a spike or a misread word must not throw the state where the
    // model cannot follow (a 1e11 rad reading once made the integrator
    // crawl for good). After a run of them, the rotor is elsewhere.
    ++outliers_;
    if (++outliers_in_a_row_ >= kOutliersToRestart) {
      model::LuGreState y = corrected_.state();
      y[model::kTheta] = theta;
      y[model::kThetaDot] = 0.0;
      y[model::kZ] = 0.0;
      corrected_.restart(t, y, last_V_);
      outliers_in_a_row_ = 0;
      ++restarts_;
    }
  } else {
    outliers_in_a_row_ = 0;
    residual = corrected_.measure(t, theta);
    const double open_error = theta - open_loop_.state()[model::kTheta];
    ++n_;
    sum_sq_residual_ += residual * residual;
    sum_sq_open_ += open_error * open_error;
    last_residual_ = residual;
  }

  const model::LuGreState& y = corrected_.state();
  out.t.push_back(t);
  out.theta_hat.push_back(y[model::kTheta]);
  out.theta_dot_hat.push_back(y[model::kThetaDot]);
  out.x_hat.push_back(y[model::kX]);
  out.z_hat.push_back(y[model::kZ]);
  out.F_hat.push_back(corrected_.friction());
  out.residual.push_back(residual);
  out.theta_open.push_back(open_loop_.state()[model::kTheta]);
}

ObserverSummary ObserverStage::summary() const {
  ObserverSummary s;
  s.samples = n_;
  s.outliers = outliers_;
  s.restarts = restarts_;
  if (n_ == 0) return s;
  const double n = static_cast<double>(n_);
  s.residual_rms_rad = std::sqrt(sum_sq_residual_ / n);
  s.open_loop_rms_rad = std::sqrt(sum_sq_open_ / n);
  s.last_residual_rad = last_residual_;
  return s;
}

}  // namespace piezo::host
