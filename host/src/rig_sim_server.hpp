#pragma once
// The simulated rig as a Modbus device: the plant advances in real time,
// the sensor's registers report its rotor (the config's register map, by
// default the Baumer OM30 one), and a holding register takes the drive
// voltage the way an analog-output module would. Serves several TCP clients
// at once and/or RTU on a serial device or pseudo-terminal, with the faults
// of [rig_sim] injected. Like an I/O module, it has a communication
// watchdog (WAGO 750-352 style registers): armed, it sets the analog output
// to 0 when no restarting request came for its timeout.

#include <modbus.h>

#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "run_config.hpp"

namespace piezo::host {

class RigSimServer {
 public:
  explicit RigSimServer(const RunConfig& config);
  ~RigSimServer();
  RigSimServer(const RigSimServer&) = delete;
  RigSimServer& operator=(const RigSimServer&) = delete;

  /// Serves Modbus TCP on host:port until the process ends.
  void serve_tcp(const std::string& host, int port);
  /// Serves Modbus RTU on `device` at the sensor link's serial settings.
  void serve_rtu(const std::string& device);

  /// What the register map and the analog output are, for the start-up line.
  [[nodiscard]] std::string describe() const;

 private:
  enum class Fault { none, drop, exception };
  /// Brings the registers up to now and decides this request's fault.
  Fault prepare_reply_locked(int function);
  /// Applies a changed analog-output register to the plant.
  void after_reply_locked();
  /// Zeroes the output once the armed watchdog has expired.
  void run_watchdog_locked(hal::TimeNs now);
  /// Replies to one request, or not, as the faults decide.
  void answer(modbus_t* ctx, const std::uint8_t* query, int length);
  /// Runs the watchdog while no request comes.
  void idle();
  [[nodiscard]] bool disconnected() const;
  [[nodiscard]] bool hanging() const;
  [[nodiscard]] double since_start_s() const;

  RunConfig config_;
  hal::posix::MonotonicClock clock_;
  hal::TimeNs t_start_;
  hal::sim::Plant plant_;
  hal::sim::SimSensor sensor_;
  modbus_mapping_t* registers_;
  std::uint16_t last_ao_counts_ = 0;
  hal::TimeNs watchdog_restarted_ = 0;
  bool late_reply_done_ = false;
  std::mutex mutex_;  // TCP and RTU may serve at once: registers and plant are shared
  std::mt19937_64 random_{7};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
};

}  // namespace piezo::host
