#pragma once
// piezod's core: owns the rig built from the board config and serves the
// command socket (ROUTER) and the sample stream (PUB) from one network
// thread; the real-time loops run under a LoopRunner beside it. Its rooms:
//   daemon.cpp          sockets, CURVE, the poll loop and the command table
//   daemon_run.cpp      a run's life: configure, start, step, stop, lease, its end
//   daemon_programs.cpp what a run follows besides a waveform: moves, calibration;
//                       the zero and readings at rest
//   daemon_scans.cpp    scans: their plan, their trigger pulses, their account
//   daemon_rest.cpp     the axes between runs: idle readings, moves at rest
//   daemon_reports.cpp  what the board says: hello, status, events (typed messages)
//   run_state.*         the state machine and its latching rules
//   command_table.*     commands, their arguments and who may send them
//   served_axis.hpp     what the board keeps for each of its axes
//   sample_hub.*        recorder, spill file, publishing and fetch

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
#include <zmq.hpp>

#include "client_authentication.hpp"
#include "command_table.hpp"
#include "config/config_file.hpp"
#include "config/rig.hpp"
#include "idle_reader.hpp"
#include "piezo/firmware/angle_zero.hpp"
#include "piezo/firmware/calibration_program.hpp"
#include "piezo/firmware/move_controller.hpp"
#include "piezo/firmware/move_planner.hpp"
#include "piezo/firmware/scan_controller.hpp"
#include "piezo/protocol/messages.hpp"
#include "run_state.hpp"
#include "sample_hub.hpp"
#include "served_axis.hpp"

namespace piezo::daemon {

class Daemon {
 public:
  /// Builds the rig (opens the hardware) and binds both sockets; throws
  /// with a clear message when either fails. `listen` overrides the
  /// config's address; `log` receives one line per event.
  Daemon(const config::BoardConfig& board, zmq::context_t& context, const std::string& listen,
         std::ostream& log);
  /// The same on a rig built by the caller (the host's one-machine default,
  /// tests that look at the simulated devices afterwards).
  Daemon(const config::BoardConfig& board, config::Rig rig, zmq::context_t& context,
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
  struct Run;  // the run under way, or the last one (daemon_run.hpp)
  /// What a run follows: the configured waveform, a closed-loop move, or
  /// the calibration experiment.
  struct Program {
    /// A move's settings on its axis: one for a move, several for a group.
    struct Move {
      ServedAxis* axis = nullptr;
      firmware::MoveSettings settings;
      firmware::TravelHeading heading;  ///< towards the target from where the axis is
    };
    std::vector<Move> moves;
    std::optional<firmware::CalibrationPlan> calibration;
    /// A scan's settings on its axis: one, or several for a group.
    struct Scan {
      ServedAxis* axis = nullptr;
      firmware::ScanSettings settings;
      firmware::TravelHeading heading;  ///< towards the run-up's start from where the axis is
    };
    std::vector<Scan> scans;
  };
  struct AtRest {
    double mean_m = 0.0, stddev_m = 0.0;
    int good = 0;
  };

  // daemon.cpp
  void bind_sockets();
  void load_calibration_file(ServedAxis& axis);
  void poll_once();
  void on_command(std::vector<zmq::message_t>& frames);
  CommandTable command_table();
  /// `axis`: the board's axes' names; required when it has several.
  [[nodiscard]] protocol::ArgumentSpec axis_spec() const;
  /// `move_to`'s: the move's request, `axis`, and a group's `targets`.
  [[nodiscard]] std::vector<protocol::ArgumentSpec> move_to_specs() const;
  void log_event(const std::string& line);
  [[nodiscard]] bool running() const { return run_state_.under_way(); }
  /// False once a run's drive loop has counted no cycle for a second on
  /// the real clock.
  [[nodiscard]] bool drive_loop_progressing();

  // daemon_run.cpp
  nlohmann::json configure(const nlohmann::json& args);
  /// The axis a request names (`axis`), or the board's one axis; throws
  /// bad_argument naming the axes there are.
  /// Refuses (fault_latched) a run on an axis whose own fault is latched.
  void require_no_axis_fault(const ServedAxis& axis, const char* cmd) const;
  /// Where a run of `axis` in `direction` (+1/-1) heads, for its travel
  /// window: from the axis's position at rest, with a stick stroke at V0
  /// as the most its first periods carry it the other way.
  [[nodiscard]] firmware::TravelHeading heading(const ServedAxis& axis, int direction,
                                                double V0) const;
  /// Refuses (out_of_limits, key `direction`) a run that would take an axis
  /// standing at or past an end of its travel window further out.
  void require_inward(const ServedAxis& axis, model::Direction towards) const;
  /// `stop`'s optional axis.
  [[nodiscard]] std::vector<protocol::ArgumentSpec> stop_specs() const;
  [[nodiscard]] ServedAxis& axis_of(const nlohmann::json& args, std::string_view cmd);
  [[nodiscard]] std::string axis_names() const;  ///< "theta, phi, chi"
  /// Checks and keeps a waveform for `axis`; `cmd` names the command in refusals.
  protocol::ConfigureRequest apply_configuration(ServedAxis& axis,
                                                 const protocol::ConfigureRequest& request,
                                                 const char* cmd);
  /// `lease_s`: the request's, if it named one (else the board's default).
  protocol::StartReply start(const std::string& client, std::optional<double> lease_s,
                             const Program& program = {}, const char* cmd = "start");
  /// The loop runner for the program, over the run's own parts.
  void build_runner(Run& run, const Program& program);
  nlohmann::json step(const std::string& client, const nlohmann::json& args);
  /// Stops the run, or (`axis`) one axis of it while the others go on.
  nlohmann::json stop_run(const nlohmann::json& args);
  nlohmann::json estop(const std::string& client);
  nlohmann::json reset_fault();
  nlohmann::json renew_lease(const nlohmann::json& args);
  void check_lease_on_wall_clock();
  void pump_samples();
  void finish_run();
  void take_calibration(Run& run);

  // daemon_programs.cpp
  nlohmann::json move_to(const std::string& client, const nlohmann::json& args);
  /// The move's settings from its request: limits, zero, noise, waveform, steps.
  firmware::MoveSettings plan_move(ServedAxis& axis, const protocol::MoveToRequest& request,
                                   bool& calibrated);
  nlohmann::json calibrate(const std::string& client, const nlohmann::json& args);
  nlohmann::json set_calibration(const std::string& client, const nlohmann::json& args);
  /// Installs a checked calibration and keeps it in the board's file.
  /// Installs `c` and keeps it in [piezod] calibration_file, if any:
  /// why it could not be saved there, or nothing.
  std::optional<std::string> install_calibration(ServedAxis& axis, protocol::CalibrationRecord c);
  nlohmann::json set_zero(const std::string& client, const nlohmann::json& args);
  /// Reads the sensor `n` times at its rate with the loops stopped and the
  /// drive at 0 V: the mean of the good readings and their spread (they
  /// also become the recent ones, so `status` says the same).
  [[nodiscard]] AtRest read_at_rest(ServedAxis& axis, std::size_t n);

  // daemon_scans.cpp
  nlohmann::json scan(const std::string& client, const nlohmann::json& args);
  /// `scan`'s arguments: one axis's, `axis`, and a group's `scans`.
  [[nodiscard]] std::vector<protocol::ArgumentSpec> scan_specs() const;
  /// One axis's scan from its request and calibration (refusals name the
  /// argument); `account` gets the scan as taken, `duration_s` its longest run.
  firmware::ScanSettings plan_scan(ServedAxis& axis, const protocol::ScanRequest& request,
                                   protocol::ScanAccount& account, double& duration_s);
  /// The pulses the scans fired since the last call: kept and streamed.
  void take_pulses(Run& run);
  /// After the loops ended: trigger lines low, the model's velocity beside each span's.
  void end_scans(Run& run);
  [[nodiscard]] protocol::ScanAccount scan_account(const Run& run, std::size_t part,
                                                   bool with_pulses) const;
  /// Each scanning part's account, without its pulses (empty: no scan).
  [[nodiscard]] std::vector<protocol::ScanAccount> scan_accounts(const Run& run) const;

  // daemon_rest.cpp
  /// Takes the idle reader's readings: positions, noise, moves at rest.
  void take_idle_readings();
  /// A new rest for every axis (the board's start, a run's end).
  void begin_rest();
  /// The simulated rig's plants carried to now (no drive writes at rest):
  /// what its sensors read at rest is where its rotors are.
  void advance_simulated_rig();
  /// What the axis's readings at rest say, for status and health.
  [[nodiscard]] protocol::RestReport rest_of(const ServedAxis& axis) const;

  // daemon_reports.cpp
  [[nodiscard]] protocol::Hello hello() const;
  /// An axis's position from its zero and its latest readings.
  [[nodiscard]] protocol::Status::Position position_of(const ServedAxis& axis) const;
  [[nodiscard]] protocol::Status status(const std::string& client) const;
  [[nodiscard]] protocol::MoveAccount move_account(const Run& run, std::size_t part) const;
  /// Each part's move account (empty: not a move).
  [[nodiscard]] std::vector<protocol::MoveAccount> move_accounts(const Run& run) const;
  [[nodiscard]] protocol::RunSummary summary(const Run& run) const;
  void publish_state();
  void publish_health();

  config::BoardConfig board_;
  /// This start's identity (hello's board_id): new at every start, so no
  /// client takes a restarted board for the one it knew.
  const std::string board_id_;
  std::ostream& log_;
  config::Rig rig_;
  zmq::context_t& context_;
  zmq::socket_t commands_, stream_;
  std::unique_ptr<ZapHandler> zap_;
  std::string command_endpoint_, stream_endpoint_;
  RunState run_state_;
  std::vector<std::unique_ptr<ServedAxis>> axes_;  ///< in the board's order
  std::optional<protocol::ConfigureRequest> configured_;
  ServedAxis* configured_axis_ = nullptr;  ///< the axis configured_ is for
  std::unique_ptr<Run> run_;
  std::uint64_t run_count_ = 0;
  SampleHub samples_;
  std::chrono::steady_clock::time_point last_health_;
  std::uint64_t last_drive_cycles_ = 0;
  std::chrono::steady_clock::time_point last_drive_progress_;
  /// Reads every sensor between runs (its thread uses the rig and axes above).
  std::unique_ptr<IdleReader> idle_;
  /// Held from a run's start to its end: the run's loops own the sensors.
  std::optional<IdleReader::Hold> run_hold_;
  CommandTable command_table_;  ///< last: its handlers use the members above
};

}  // namespace piezo::daemon
