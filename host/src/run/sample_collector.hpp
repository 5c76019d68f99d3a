#pragma once
// Samples from the firmware (a ring in-process, or frames from piezod) to
// log columns, with the observer fed as they come.

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>

#include "io/run_log.hpp"
#include "observer_stage.hpp"
#include "piezo/firmware/angle_zero.hpp"
#include "piezo/firmware/samples.hpp"

namespace piezo::host {

using firmware::DriveSample;
using firmware::SensorSample;

/// Turns ring samples into log columns; theta is the displacement change
/// from the zero (the board's, for a move; else the first good reading:
/// firmware::AngleZero's rule, the board's too) over r2 (docs/model.md
/// section 4).
class SampleCollector {
 public:
  /// `zero_m`: the displacement the angle is measured from (a move's: the
  /// board's zero); NaN: the first good reading.
  SampleCollector(hal::TimeNs t0, double r2, ObserverStage* observer,
                  double zero_m = std::numeric_limits<double>::quiet_NaN())
      : t0_(t0), r2_(r2), observer_(observer), zero_(zero_m) {}

  void add(const DriveSample& s) {
    if (s.status != hal::Status::ok) ++drive_errors_[std::string(hal::to_string(s.status))];
    const double t = hal::to_seconds(s.t - t0_);
    if (observer_ != nullptr) observer_->on_drive(t, s.V, rows_.observer);
    auto& d = rows_.drive;
    d.t.push_back(t);
    d.V.push_back(s.V);
    d.phase.push_back(static_cast<double>(s.phase));
    d.status.push_back(static_cast<double>(s.status));
    d.move_state.push_back(static_cast<double>(s.move_state));
    d.t_received.push_back(received_s_);
    last_V_ = s.V;
    last_t_ = t;
  }

  void add(const SensorSample& s) {
    const bool good = s.status == hal::Status::ok;
    if (!good) ++sensor_errors_[std::string(hal::to_string(s.status))];
    if (good) zero_.offer(s.displacement_m);
    const double theta =
        good ? zero_.angle_rad(s.displacement_m, r2_) : std::numeric_limits<double>::quiet_NaN();
    const double t = hal::to_seconds(s.t_request - t0_);
    auto& r = rows_.sensor;
    r.t.push_back(t);
    r.t_response.push_back(hal::to_seconds(s.t_response - t0_));
    r.displacement_m.push_back(s.displacement_m);
    r.theta.push_back(theta);
    r.status.push_back(static_cast<double>(s.status));
    r.t_received.push_back(received_s_);
    if (good) {
      last_theta_ = theta;
      last_good_t_ = t;
      if (observer_ != nullptr) observer_->on_measurement(t, theta, rows_.observer);
    }
  }

  /// When the host received the samples added next: host time mapped onto
  /// the board's run time by the clock mapping [s].
  void set_received(double t_received_s) { received_s_ = t_received_s; }

  LogRows& rows() { return rows_; }
  [[nodiscard]] double last_theta() const { return last_theta_; }
  [[nodiscard]] double last_good_t() const { return last_good_t_; }
  [[nodiscard]] double last_V() const { return last_V_; }
  /// Run time of the newest drive sample [s].
  [[nodiscard]] double last_t() const { return last_t_; }
  [[nodiscard]] const std::map<std::string, std::uint64_t>& drive_errors() const {
    return drive_errors_;
  }
  [[nodiscard]] const std::map<std::string, std::uint64_t>& sensor_errors() const {
    return sensor_errors_;
  }

 private:
  hal::TimeNs t0_;
  double r2_;
  ObserverStage* observer_;
  firmware::AngleZero zero_;
  double last_theta_ = 0.0, last_good_t_ = 0.0, last_V_ = 0.0, last_t_ = 0.0;
  double received_s_ = std::numeric_limits<double>::quiet_NaN();
  LogRows rows_;
  std::map<std::string, std::uint64_t> drive_errors_, sensor_errors_;
};

}  // namespace piezo::host
