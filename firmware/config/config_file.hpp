#pragma once
// A rig config: read from a TOML file plus --set SECTION.KEY=VALUE
// overrides and checked as a whole before anything touches the hardware.
// Each process takes its own part: the board (piezod, or the board `piezo`
// starts in-process) its BoardConfig, the host's `piezo` its HostConfig,
// `piezo rig-sim` the board's devices and its RigSimConfig.

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/config/section_reader.hpp"
#include "piezo/firmware/move_request.hpp"
#include "piezo/firmware/request_arguments.hpp"
#include "piezo/firmware/safety_supervisor.hpp"
#include "piezo/firmware/voltage_limiter.hpp"
#include "piezo/hal/backend.hpp"
#include "piezo/hal/backends.hpp"
#include "piezo/hal/sim/modbus_rig_device.hpp"
#include "piezo/model/lugre_observer.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::config {

/// The run's clock: the board's, or the simulated rig's virtual one.
enum class RunClock { realtime, virtual_time };

inline constexpr auto kRunClockNames =
    names<RunClock>({{RunClock::realtime, "realtime"}, {RunClock::virtual_time, "virtual"}});

[[nodiscard]] std::string_view name(RunClock c);

/// One kind's backends: every one the build has (hal/registry), each with
/// its own section read, and the `backend` key's choice among them.
template <class Base>
struct Backends {
  std::string backend;  ///< the chosen one's name
  std::vector<std::shared_ptr<Base>> all;

  [[nodiscard]] const Base& chosen() const {
    for (const auto& b : all)
      if (b->name() == backend) return *b;
    throw std::logic_error("no backend named " + backend);
  }
  /// The backend of type T (the first, when transports share one section).
  template <class T>
  [[nodiscard]] const T& get() const {
    for (const auto& b : all)
      if (const auto* t = dynamic_cast<const T*>(b.get())) return *t;
    throw std::logic_error("no such backend");
  }
};

/// [drive]: the waveform's limits and the backend that puts it out (its
/// rate is the board's: BoardConfig::drive_rate_hz).
struct DriveSettings {
  firmware::VoltageLimits limits{0.0, 80.0, 20'000.0};
  double amplifier_gain = 20.0;  ///< piezo volts per volt at the backend's output
  Backends<hal::DriveBackend> backends{"sim", hal::drive_backends()};

  [[nodiscard]] const std::string& backend() const { return backends.backend; }
};

/// [sensor]: the sensor's geometry and range, and its backend (its rate is
/// the board's: BoardConfig::sensor_rate_hz).
struct SensorSettings {
  double r2_m = hal::kDefaultSensorRadius_m;  ///< reflector radius: theta = (d - d_tare) / r2
                                              ///< (docs/model.md section 4)
  /// The sensor's measuring range [m]: readings outside are out_of_range.
  /// The defaults only catch the absurd (a wrong word order reads 1e9 m);
  /// set them to the sensor's data sheet.
  double range_min_m = -10.0;
  double range_max_m = 10.0;
  Backends<hal::SensorBackend> backends{"sim", hal::sensor_backends()};

  [[nodiscard]] const std::string& backend() const { return backends.backend; }
};

struct LinesSettings {
  Backends<hal::LinesBackend> backends{"sim", hal::lines_backends()};

  [[nodiscard]] const std::string& backend() const { return backends.backend; }
};

struct ObserverSettings {
  bool enabled = true;
  model::ObserverGains gains;
};

/// [run] as the board reads it: the clock and the drive loop's scheduling.
struct BoardRunSettings {
  RunClock clock = RunClock::realtime;
  int priority = 80;  ///< SCHED_FIFO priority of the drive loop (0: do not ask)
  bool lock_memory = true;
};

/// [run] and [move] as the host reads them (what a command asks a board
/// to run travels beside the config: host/src/run/board_request.hpp).
struct RunSettings {
  double duration_s = 4.8;
  double flush_interval_s = 0.25;  ///< log flush period: the most a crash can lose
  /// [move]: the defaults of `piezo move`'s options (the target aside).
  firmware::MoveRequest move_defaults;
};

/// The board's daemon ([piezod]): where it listens, what a client may ask.
struct DaemonSettings {
  std::string listen = "tcp://127.0.0.1:5555";  ///< command socket; the stream is on port + 1
  double lease_s =
      firmware::arguments::kDefaultLease_s;  ///< a start's lease when the client names none
  double lease_max_s = 10.0;                 ///< the longest lease a client may ask for
  double recorder_s = 120.0;                 ///< samples kept on the board, at the configured rates
  /// Every sample of the current run also goes to this file (empty: none),
  /// so a fetch reaches past the memory ring.
  std::string spill_file;
  /// Where the board keeps its calibration across restarts (empty: in
  /// memory only, until the daemon stops).
  std::string calibration_file;
  double duration_max_s = 86'400.0;
  /// What each client's fetches may take, samples per second (bursts up to
  /// one largest fetch, 100000): a flood of them costs the board this much.
  double fetch_samples_per_s = 1e6;
  /// Between runs every axis's sensor is read at this rate, the drive at
  /// 0 V (0: not at all; no position at rest then, no move at rest seen).
  double idle_rate_hz = 20.0;
  /// Network binds need CURVE: the server's secret key (Z85, from `piezod
  /// keygen`) and the clients' public keys, one per line.
  std::string secret_key_file;
  std::string authorized_keys_file;
  bool insecure = false;  ///< plain text on a network address (logged)
};

/// The host's side ([rig]): which piezod to drive. Empty address: the
/// one-machine default, the firmware started by the host itself.
struct BoardAddress {
  std::string address;
  std::string server_public_key_file;  ///< CURVE: the board's public key (Z85)
  std::string client_secret_key_file;  ///< CURVE: this host's key pair, from `piezod keygen`
  double lease_s = 0.0;                ///< the lease a run asks for; 0: the board's default
  /// The board's axis this host's commands drive (empty: the board's one
  /// axis; a board of several asks for one).
  std::string axis;
};

/// The name of a board's one axis when its config declares no [axes].
inline constexpr std::string_view kDefaultAxisName = "rotor";

/// One axis of a board: a motor with its own drive, sensor, plant and
/// limits. A config without [axes] has one, from the file's own sections;
/// each [axes.NAME] overlays them for that axis (docs/configuration.md).
struct AxisConfig {
  std::string name{kDefaultAxisName};
  model::Parameters model;       ///< [drive] waveform + [model]: the axis's defaults
  model::MotorParameters plant;  ///< [model] overlaid with [plant]: the simulated rig's
  /// [plant] end_stop_rad: the simulated rotor's end stop (NaN: none).
  double plant_end_stop_rad = std::numeric_limits<double>::quiet_NaN();
  /// [plant] coupling: the share of every other axis's stator stroke this
  /// axis's simulated stator takes (crosstalk; 0: none).
  double plant_coupling = 0.0;
  DriveSettings drive;
  SensorSettings sensor;
  firmware::SafetySettings safety;
};

/// What the board reads (piezod, or the board the host starts in-process):
/// its axes, their devices and limits, its lines, its defaults and its daemon.
struct BoardConfig {
  std::string source;  ///< the config file, for messages
  /// At least one; in the file's order. One tick drives them all.
  std::vector<AxisConfig> axes = std::vector<AxisConfig>(1);
  /// The board's loop rates ([drive] and [sensor] rate_hz; an axis's own
  /// sections may not name another): one tick drives every axis, and each
  /// sensor line reads at this rate.
  double drive_rate_hz = 10'000.0;
  double sensor_rate_hz = 1'000.0;
  LinesSettings lines;
  BoardRunSettings run;
  /// [safety] fault_stops_all: an axis's own fault stops every axis.
  bool fault_stops_all = false;
  DaemonSettings daemon;

  [[nodiscard]] const AxisConfig& axis(std::size_t i = 0) const { return axes.at(i); }
  [[nodiscard]] AxisConfig& axis(std::size_t i = 0) { return axes.at(i); }
  /// The axis named `name`, or null.
  [[nodiscard]] const AxisConfig* find_axis(std::string_view name) const;
  /// The index of the axis `name` names, as an edge (a command line, a
  /// request) gives it: empty takes a config's one axis; an unknown name, or
  /// none on a config of several, throws ConfigError (`where`, key `axis`)
  /// listing the config's axes. Never another axis for a name it lacks.
  [[nodiscard]] std::size_t axis_index(std::string_view name, const std::string& where) const;
  [[nodiscard]] bool virtual_clock() const { return run.clock == RunClock::virtual_time; }
  /// What an axis's drive backends take from its [drive] (and whether [lines] has an enable line).
  [[nodiscard]] hal::DriveCommon drive_common(std::size_t axis = 0) const {
    const DriveSettings& d = axes.at(axis).drive;
    return {drive_rate_hz, d.amplifier_gain, lines.backend() != "none"};
  }
  /// What an axis's sensor backends take: the board's rate, its radius.
  [[nodiscard]] hal::SensorCommon sensor_common(std::size_t axis = 0) const {
    return {sensor_rate_hz, axes.at(axis).sensor.r2_m};
  }
};

/// What the host's `piezo` reads: the run it asks for, how it watches it
/// and which board drives it.
struct HostConfig {
  model::Parameters
      model;  ///< [drive] waveform + [model]: what a run asks, what the observer models
  RunSettings run;
  ObserverSettings observer;
  BoardAddress board;  ///< [rig]: the rig's board (piezod) to drive
};

/// What `piezo rig-sim` reads beyond the devices it serves (the board's).
struct RigSimConfig {
  hal::sim::ModbusDeviceFaults faults;  ///< the faults it shows
  hal::sim::TcpLimits tcp;              ///< what its TCP clients may hold
};

/// A config file: each process's part of it. One file may serve all three
/// (the one-machine default); each process takes only its own part.
struct ConfigFile {
  std::string source;  ///< the config file
  std::string text;    ///< the file's text plus the --set lines: stored with the log
  BoardConfig board;
  HostConfig host;
  RigSimConfig rig_sim;
};

/// What a command needs of a config: a whole rig, or only its sensor.
enum class ConfigScope { whole, sensor };

/// Reads and checks a rig config. Throws ConfigError naming the key, the
/// source (the file, or "--set") and what is allowed.
[[nodiscard]] ConfigFile load_config_file(const std::string& path,
                                          const std::vector<std::string>& sets = {},
                                          ConfigScope scope = ConfigScope::whole);

/// The same over several files, each overlaying the ones before it.
[[nodiscard]] ConfigFile load_config_file(const std::vector<std::string>& paths,
                                          const std::vector<std::string>& sets,
                                          ConfigScope scope = ConfigScope::whole);

/// A run command's own options for the drive, given as values (never as
/// `--set` text): each given one overrides its key after the files and
/// `--set`, is checked with the rest, and a refusal names the option.
struct DriveOptions {
  std::optional<double> V0, f, duration_s;
  bool reverse = false;
};

/// The files and `--set`, then the command's drive options.
[[nodiscard]] ConfigFile load_config_file(const std::vector<std::string>& paths,
                                          const std::vector<std::string>& sets,
                                          const DriveOptions& options);

/// Table 1 defaults overlaid with a config file's [drive] waveform and
/// [model]; a rig config's other sections are read and checked too.
[[nodiscard]] model::Parameters load_model_config(const std::string& path);

/// Every key the readers accept, each declared where it is read (its unit,
/// range or choices, and default): what docs/configuration.md documents.
[[nodiscard]] KeyDeclarations declared_keys();

/// Every key the readers read, with its value in `c` (a declaration's
/// default is the value): the board's and the host's sections with the
/// first axis's as the base, then each axis's own (`axes.NAME.SECTION.KEY`),
/// each kind's chosen backend's section alone. What effective_config.cpp writes.
[[nodiscard]] KeyDeclarations effective_keys(const ConfigFile& c);

/// Checks an axis's drive limits against what its built drive hardware can do.
void check_drive_hardware(const BoardConfig& config, std::size_t axis, double hardware_V_min,
                          double hardware_V_max);

}  // namespace piezo::config
