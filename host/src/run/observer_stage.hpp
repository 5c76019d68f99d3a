#pragma once
// The model beside the measurement during a run: the corrected LuGre
// observer and the open-loop prediction, fed with the drive commands and
// the measured angles in time order, logged under /observer.

#include <cmath>
#include <cstdint>
#include <deque>
#include <utility>

#include "io/log_schema.hpp"
#include "piezo/model/lugre_observer.hpp"

namespace piezo::host {

struct ObserverSummary {
  std::uint64_t samples = 0;
  double residual_rms_rad = 0.0;   ///< measured minus the observer's prediction, before correction
  double open_loop_rms_rad = 0.0;  ///< measured minus the open-loop model
  double last_residual_rad = 0.0;
  std::uint64_t outliers = 0;  ///< measurements beyond the gate, not used to correct
  std::uint64_t restarts = 0;  ///< times the observer started again at the measured angle
};

class ObserverStage {
 public:
  /// Commands reach the output `latency` [s] after their deadline and take
  /// `ramp_time` [s] to settle.
  ObserverStage(const model::MotorParameters& model, const model::ObserverGains& gains,
                double ramp_time, double latency);

  /// A drive command (deadline time [s], volts). Measurements up to t are
  /// processed now: the drive is known up to there.
  void on_drive(double t, double V, log_schema::ObserverRows& out);
  /// A good angle measurement at time t [s]; one further than the gate
  /// from the prediction is logged but not used to correct. The two rings arrive
  /// independently, so it waits until the drive is known up to t; each
  /// processed measurement appends a row to `out`.
  void on_measurement(double t, double theta, log_schema::ObserverRows& out);
  /// Processes the measurements still waiting (the run has ended).
  void finish(log_schema::ObserverRows& out);

  [[nodiscard]] ObserverSummary summary() const;

 private:
  void feed_commands_until(double t);
  void process(double t, double theta, log_schema::ObserverRows& out);
  void process_measurements_until(double t, log_schema::ObserverRows& out);

  model::LuGreObserver corrected_;
  model::LuGreObserver open_loop_;
  std::deque<std::pair<double, double>> pending_commands_, pending_measurements_;
  double drive_known_until_ = -1.0;
  double latency_;
  /// Outliers in a row after which the measurement is believed over the
  /// model: the observer restarts there instead of integrating on from a
  /// state the rotor left (or, fed absurd readings, from an absurd one).
  static constexpr std::uint64_t kOutliersToRestart = 8;
  double gate_rad_;
  double last_V_ = 0.0;  ///< the input last fed to the observer
  std::uint64_t n_ = 0, outliers_ = 0, outliers_in_a_row_ = 0, restarts_ = 0;
  double sum_sq_residual_ = 0.0, sum_sq_open_ = 0.0, last_residual_ = 0.0;
};

}  // namespace piezo::host
