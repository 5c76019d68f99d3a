#pragma once
// piezod's core: owns the rig built from the board config, serves the
// command socket (ROUTER) and the sample stream (PUB), runs the state
// machine, the recorder and the lease. One network thread does all of it;
// the real-time loops run under a LoopRunner beside it.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>
#include <zmq.hpp>

#include "curve.hpp"
#include "fetch_budget.hpp"
#include "piezo/firmware/calibration_program.hpp"
#include "piezo/firmware/loop_runner.hpp"
#include "piezo/firmware/move_controller.hpp"
#include "piezo/firmware/run_guard.hpp"
#include "piezo/model/waveform.hpp"
#include "recorder.hpp"
#include "rig.hpp"
#include "run_config.hpp"
#include "spill_file.hpp"

namespace piezo::daemon {

enum class State { idle, running, ramping_down, fault };
[[nodiscard]] const char* to_string(State s);

class Daemon {
 public:
  /// Builds the rig (opens the hardware) and binds both sockets; throws
  /// with a clear message when either fails. `listen` overrides the
  /// config's address; `log` receives one line per event.
  Daemon(const config::RunConfig& board, zmq::context_t& context, const std::string& listen,
         std::ostream& log);
  /// The same on a rig built by the caller (the host's one-machine default,
  /// tests that look at the simulated devices afterwards).
  Daemon(const config::RunConfig& board, config::Rig rig, zmq::context_t& context,
         const std::string& listen, std::ostream& log);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Serves until `stop` is set; a run under way is stopped (ramp to 0 V,
  /// amplifier disabled) before it returns. `alive` is called from every
  /// turn of the loop while the daemon and a run's drive loop make progress
  /// (the service watchdog): a hung daemon or drive loop stops calling it.
  void serve(const std::atomic<bool>& stop, const std::function<void()>& alive = {});

  [[nodiscard]] const std::string& command_endpoint() const { return command_endpoint_; }
  [[nodiscard]] const std::string& stream_endpoint() const { return stream_endpoint_; }

 private:
  struct RunRequest {
    model::DriveParameters drive;
    double duration_s = 0.0;
  };
  struct Run;  // the run under way, or the last one

  void poll_once();
  void on_command(std::vector<zmq::message_t>& frames);
  nlohmann::json handle(const std::string& client, const std::string& cmd,
                        const nlohmann::json& args);
  nlohmann::json hello() const;
  nlohmann::json status(const std::string& client) const;
  /// `cmd` names the command in refusals (step and move_to configure too).
  nlohmann::json configure(const std::string& client, const nlohmann::json& args,
                           const char* cmd = "configure");
  /// What a run follows: the configured waveform, a closed-loop move, or
  /// the calibration experiment.
  struct Program {
    std::optional<firmware::MoveSettings> move;
    std::optional<firmware::CalibrationPlan> calibration;
  };
  nlohmann::json start(const std::string& client, const nlohmann::json& args,
                       const Program& program = {}, const char* cmd = "start");
  nlohmann::json step(const std::string& client, const nlohmann::json& args);
  nlohmann::json move_to(const std::string& client, const nlohmann::json& args);
  nlohmann::json calibrate(const std::string& client, const nlohmann::json& args);
  nlohmann::json set_calibration(const std::string& client, const nlohmann::json& args);
  /// Installs a checked calibration and keeps it in the board's file.
  void install_calibration(nlohmann::json c);
  nlohmann::json set_zero(const std::string& client);
  nlohmann::json position_json() const;
  nlohmann::json move_json(const Run& run) const;
  nlohmann::json stop_run(const std::string& client);
  nlohmann::json estop(const std::string& client);
  nlohmann::json reset_fault();
  nlohmann::json renew_lease(const std::string& client, const nlohmann::json& args);
  nlohmann::json fetch(const std::string& client, const nlohmann::json& args);
  void require_controller(const std::string& client, const char* cmd) const;
  /// Refuses `cmd` (start, step, move_to) under a latched fault or a run.
  void require_can_start(const std::string& client, const char* cmd) const;
  void pump_samples();
  void publish_state();
  void publish_health();
  void finish_run();
  void check_lease_on_wall_clock();
  void log_event(const std::string& line);
  [[nodiscard]] bool running() const;
  /// False once a run's drive loop has counted no cycle for a second on
  /// the real clock.
  [[nodiscard]] bool drive_loop_progressing();

  config::RunConfig board_;
  std::ostream& log_;
  config::Rig rig_;
  zmq::context_t& context_;
  zmq::socket_t commands_, stream_;
  std::unique_ptr<ZapHandler> zap_;
  std::string command_endpoint_, stream_endpoint_;
  State state_ = State::idle;
  firmware::StopCause fault_cause_ = firmware::StopCause::none;
  std::optional<RunRequest> configured_;
  std::unique_ptr<Run> run_;
  std::uint64_t run_count_ = 0;
  std::string controller_;  ///< routing id of the controlling client, while a run is on
  Recorder<firmware::DriveSample> drive_recorder_;
  Recorder<firmware::SensorSample> sensor_recorder_;
  std::optional<SpillFile> spill_;
  FetchBudget fetch_budget_;
  std::uint64_t drive_published_ = 0, sensor_published_ = 0;
  /// The user's zero of the angle (a displacement [m]): set by `zero`, or
  /// else the first good reading since the daemon started.
  std::optional<double> zero_displacement_m_;
  /// The installed calibration (docs/protocol.md, "Calibration"), if any.
  std::optional<nlohmann::json> calibration_;
  static constexpr std::size_t kZeroReadings = 8;  ///< averaged for a zero or a position
  std::vector<double> zero_readings_;              ///< toward the zero at the start
  std::deque<double> recent_readings_;             ///< the last good readings of any run
  [[nodiscard]] std::optional<double> recent_displacement_m() const;
  /// Reads the sensor kZeroReadings times at its rate, after a run with the
  /// loops stopped and the drive at 0 V: the mean of the good readings (they
  /// also become the recent ones, so `status` says the same).
  struct AtRest {
    double mean_m = 0.0, stddev_m = 0.0;
    int good = 0;
  };
  [[nodiscard]] std::optional<double> read_at_rest();
  /// The same for `n` readings, with their spread.
  [[nodiscard]] AtRest read_at_rest(std::size_t n);
  std::chrono::steady_clock::time_point last_health_;
  std::uint64_t last_drive_cycles_ = 0;
  std::chrono::steady_clock::time_point last_drive_progress_;
};

}  // namespace piezo::daemon
