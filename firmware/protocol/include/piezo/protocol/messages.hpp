#pragma once
/// @file
/// The protocol's messages as types (docs/protocol.md): the board encodes
/// them and the host decodes them through these, and nowhere else. Each
/// converts to and from the JSON value that travels as a MessagePack map
/// (nlohmann's to_json/from_json, found by argument-dependent lookup). A
/// reply's or an event's codec is generated from its one field list
/// (messages.cpp, wire_fields.hpp); a request's keys are its arguments'
/// declared names (request_arguments.hpp). Decoding a map that lacks a
/// field, or holds one of the wrong type, throws ProtocolError (malformed,
/// naming the field). Optional fields are nil on the wire when absent.

#include <array>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/firmware/move_state.hpp"
#include "piezo/firmware/output_state.hpp"
#include "piezo/firmware/request_arguments.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/firmware/stop_cause.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/protocol/board_state.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/request_fields.hpp"
#include "piezo/protocol/wire_fields.hpp"

namespace piezo::protocol {

/// The board's calibration (docs/protocol.md, "Calibration"): what
/// `calibrate` measured (the step table by direction, amplitude and
/// frequency, the angle per volt in stick, the sensor's noise), the figures
/// derived from it, and a host's fitted model beside it.
struct CalibrationRecord {
  static constexpr int kVersion = 1;
  int version = kVersion;
  std::string created;  ///< the board's UTC time, ISO 8601
  double V0 = 0.0, D = 0.0, r2_m = 0.0;
  std::uint32_t steps_per_point = 0;
  struct RestReadings {
    std::uint32_t skipped = 0, averaged = 0;
  };
  std::optional<RestReadings> rest_readings;
  std::vector<double> step_fractions;  ///< of V0, as the board steps them
  double noise_m = 0.0, rad_per_V = 0.0;
  /// One frequency's steps per period at each step fraction [rad], and
  /// (derived) whether they are reliable and how fast it moves.
  struct Frequency {
    double f_hz = 0.0;
    std::vector<double> forward_rad, reverse_rad;
    std::optional<bool> reliable;
    std::optional<double> speed_rad_per_s;
  };
  std::vector<Frequency> frequencies;
  nlohmann::json model;  ///< a host's fitted model (parameters, intervals), or nil
  // Derived on the board from the above (recomputed whenever one is taken).
  std::optional<double> step_floor_rad, fastest_f_hz, noise_rad, resolution_rad,
      smallest_tolerance_rad;
};

/// One of the board's axes as `hello` lists it: its name (what `axis`
/// takes), its sensor's radius, its drive's limits, its travel window, its
/// backends, its zero and its calibration.
struct AxisInfo {
  std::string name;
  double r2_m = 0.0;
  double V_min = 0.0, V_max = 0.0, slew_V_per_s = 0.0;
  std::optional<double> travel_min_rad, travel_max_rad;  ///< nil: no end there
  std::string drive, sensor;                             ///< its backends
  std::optional<double> zero_displacement_m;
  std::optional<CalibrationRecord> calibration;
  /// A scan's velocity range, from the calibration's rising branch (nil:
  /// uncalibrated): the highest steady velocity and the slowest (Sardana's
  /// base rate) [rad/s].
  std::optional<double> velocity_max_rad_per_s, base_rate_rad_per_s;
  bool trigger = false;  ///< a trigger line is wired for its scans
};

/// `hello`'s reply: what a client needs before it asks for anything, and to
/// interpret the samples (each axis's sensor radius). Its top-level fields
/// are the board's; everything of an axis is in `axes`, for one as for ten.
struct Hello {
  std::uint32_t protocol = 0;
  /// This start of the board, new at each: a request naming another one is
  /// refused (`stale_board`), so nothing sent to a board before it
  /// restarted acts on the new one.
  std::string board_id;
  std::uint32_t frame_version = 0;
  std::string daemon;  ///< piezod's version
  std::string stream;  ///< the PUB endpoint
  std::string clock;   ///< "realtime" or "virtual"
  struct Backends {
    std::string lines;  ///< the enable and e-stop lines' (each axis's drive and sensor: `axes`)
  } backends;
  /// The board's limits. V_min, V_max and slew_V_per_s are the widest of its
  /// axes' (the dictionary's bounds); each axis's own are in `axes`.
  struct Limits {
    double V_min = 0.0, V_max = 0.0, slew_V_per_s = 0.0, ramp_down_V_per_s = 0.0,
           sensor_stale_s = 0.0, f_max_hz = 0.0, duration_max_s = 0.0, lease_max_s = 0.0;
  } limits;
  double drive_rate_hz = 0.0;
  double sensor_rate_hz = 0.0;
  double output_latency_s = 0.0;  ///< the slowest of the axes' drives
  double lease_s = 0.0;
  double recorder_s = 0.0;
  std::vector<AxisInfo> axes;  ///< in the board's order, one or several
};

/// A loop's health counters, and its period-error statistics where given
/// (health events and run summaries).
struct LoopHealth {
  std::uint64_t cycles = 0, overruns = 0, missed_cycles = 0, dropped = 0, errors = 0;
  struct Timing {
    double p50_us = 0.0, p99_us = 0.0, max_us = 0.0, mean_us = 0.0;
    std::vector<double> histogram_us;  ///< counts per 1 us bin of period error
  };
  std::optional<Timing> timing;
};

/// `clock`'s reply: the board's clock when it answered.
struct ClockReply {
  std::int64_t board_ns = 0;
};

// Requests decode through the argument readers (message.hpp), so a missing
// or mistyped argument is `bad_argument`. Each request's `kArgs` lists the
// arguments it takes, as declared in request_arguments.hpp: the board's
// command table refuses any other (naming these), and docs/protocol.md's
// argument tables are checked against them.

/// `configure`'s arguments.
struct ConfigureRequest {
  static constexpr std::string_view kCommand = "configure";
  static constexpr std::array<firmware::Argument, 6> kArgs{
      firmware::arguments::V0,   firmware::arguments::f,         firmware::arguments::C_dr,
      firmware::arguments::e_dr, firmware::arguments::direction, firmware::arguments::duration_s};
  model::DriveParameters drive;
  double duration_s = 0.0;
};

/// `start`'s arguments (the run `configure` set).
struct StartRequest {
  static constexpr std::string_view kCommand = "start";
  std::optional<double> lease_s;  ///< absent: the board's `daemon.lease_s`
};
template <>
struct RequestFields<StartRequest> {
  static constexpr auto list =
      std::tuple{argument_field(firmware::arguments::lease_s, &StartRequest::lease_s)};
};

/// `step`'s arguments.
struct StepRequest {
  static constexpr std::string_view kCommand = "step";
  static constexpr std::array<firmware::Argument, 7> kArgs{
      firmware::arguments::count,  firmware::arguments::V0,   firmware::arguments::f,
      firmware::arguments::C_dr,   firmware::arguments::e_dr, firmware::arguments::direction,
      firmware::arguments::lease_s};
  std::uint64_t count = 0;
  model::DriveParameters drive;
  std::optional<double> lease_s;
};

/// `move_to`'s arguments (absent ones take the board's defaults): every
/// field of firmware::kMoveFields, then these.
struct MoveToRequest {
  static constexpr std::string_view kCommand = "move_to";
  static constexpr std::array<firmware::Argument, 5> kWaveformArgs{
      firmware::arguments::V0.defaulting("the board's `[drive]` V0"),
      firmware::arguments::f.defaulting(
          "the calibration's `fastest_f_hz` when the board is calibrated at this `V0`, else the "
          "board's `[drive]` f"),
      firmware::arguments::C_dr.defaulting("the board's `[drive]` C_dr"),
      firmware::arguments::e_dr.defaulting("the board's `[drive]` e_dr"),
      firmware::arguments::lease_s};
  firmware::MoveRequest move;
  std::optional<double> V0, f, C_dr, e_dr, lease_s;
};

/// `calibrate`'s arguments.
struct CalibrateRequest {
  static constexpr std::string_view kCommand = "calibrate";
  std::optional<double> V0;  ///< absent: the board's drive.V0 within its V_max
  std::optional<double> lease_s;
};
template <>
struct RequestFields<CalibrateRequest> {
  using T = CalibrateRequest;
  static constexpr auto list = std::tuple{
      argument_field(
          firmware::arguments::V0.defaulting("the board's `[drive]` V0, at most `V_max`"), &T::V0),
      argument_field(firmware::arguments::lease_s, &T::lease_s)};
};

/// `scan`'s arguments for one axis (a group's: each entry of `scans`).
struct ScanRequest {
  static constexpr std::string_view kCommand = wire_key::scan;
  double from_rad = 0.0, to_rad = 0.0, velocity_rad_per_s = 0.0;
  std::optional<double> acceleration_s, deceleration_s;
  std::optional<double> trigger_step_rad, trigger_start_rad, trigger_end_rad, trigger_width_s,
      trigger_pre_start_rad;
  std::optional<std::uint64_t> trigger_pulses;
  std::optional<double> lease_s;
};
template <>
struct RequestFields<ScanRequest> {
  using T = ScanRequest;
  static constexpr auto list = std::tuple{
      argument_field(firmware::arguments::from_rad, &T::from_rad),
      argument_field(firmware::arguments::to_rad, &T::to_rad),
      argument_field(firmware::arguments::velocity_rad_per_s, &T::velocity_rad_per_s),
      argument_field(firmware::arguments::acceleration_s, &T::acceleration_s),
      argument_field(firmware::arguments::deceleration_s, &T::deceleration_s),
      argument_field(firmware::arguments::trigger_step_rad, &T::trigger_step_rad),
      argument_field(firmware::arguments::trigger_start_rad, &T::trigger_start_rad),
      argument_field(firmware::arguments::trigger_pulses, &T::trigger_pulses),
      argument_field(firmware::arguments::trigger_end_rad, &T::trigger_end_rad),
      argument_field(firmware::arguments::trigger_width_s, &T::trigger_width_s),
      argument_field(firmware::arguments::trigger_pre_start_rad, &T::trigger_pre_start_rad),
      argument_field(firmware::arguments::lease_s, &T::lease_s)};
};

/// `lease`'s arguments: the drive samples the controller has logged (its
/// acknowledgement; a virtual-clock board waits on it).
struct LeaseRequest {
  static constexpr std::string_view kCommand = "lease";
  std::optional<std::uint64_t> drive_received;
};
template <>
struct RequestFields<LeaseRequest> {
  static constexpr auto list = std::tuple{
      argument_field(firmware::arguments::drive_received, &LeaseRequest::drive_received)};
};

/// `fetch`'s arguments: `count` recorded samples of `stream` from `first`.
struct FetchRequest {
  static constexpr std::string_view kCommand = "fetch";
  Stream stream = Stream::drive;
  std::uint64_t first = 0, count = 0;
};
template <>
struct RequestFields<FetchRequest> {
  using T = FetchRequest;
  static constexpr auto list =
      std::tuple{argument_field(firmware::arguments::stream, &T::stream),
                 argument_field(firmware::arguments::first, &T::first),
                 argument_field(firmware::arguments::fetch_count, &T::count)};
};

/// How the drive's output ended (a run summary's `output`).
struct OutputEnd {
  firmware::OutputState state = firmware::OutputState::confirmed;
  bool zero_confirmed = false;
  bool zero_read_back = false;  ///< 0 V measured on an input, not only acknowledged
  std::optional<double> acknowledged_V;
  std::uint32_t zero_writes = 0;
  std::string zero_status = "ok";
  bool enabled_ever = true;
  std::string enable_status = "ok";
};

/// A closed-loop move's account: its progress while it runs (health,
/// status) and its result once it ended (the run's summary).
struct MoveAccount {
  std::string axis;  ///< the axis it moves
  firmware::MoveState state = firmware::MoveState::none;
  double target_rad = 0.0, tolerance_rad = 0.0;
  std::optional<double> position_rad, error_rad;  ///< nil before any good reading
  bool on_target = false;
  std::optional<double> on_target_at_s;
  std::uint64_t steps = 0;
  double f_hz = 0.0;
  std::optional<double> noise_m;
  /// With hold_s > 0: how closely the fine servo held the target.
  struct Hold {
    double hold_s = 0.0;
    std::optional<double> hold_rms_error_rad, hold_max_error_rad;
  };
  std::optional<Hold> hold;
  std::optional<firmware::MoveEnd> stop_cause;  ///< once the move ended
};

/// A fired trigger: the `trigger` event, and each row of a scan's pulses.
struct TriggerPulse {
  std::uint32_t k = 0;
  double position_rad = 0.0;  ///< start + k·step in the scan's direction
  double angle_rad = 0.0;     ///< the filtered measured angle that passed it
  double reading_s = 0.0;     ///< that reading's time [s from the run's t0]
  double edge_s = 0.0;        ///< the pulse's rising edge [s from the run's t0]
  bool late = false;  ///< its reading passed more than one position, or it waited for another
};

/// The `trigger` event: one per pulse, as the board fired it.
struct TriggerEvent {
  std::string board_id;
  std::uint64_t run = 0;
  std::string axis;
  TriggerPulse pulse;
};

/// A scan's account: its request as taken, its progress while it runs and
/// what it measured once it ended (the run's summary, with every pulse).
struct ScanAccount {
  std::string axis;
  double from_rad = 0.0, to_rad = 0.0, velocity_rad_per_s = 0.0;
  double acceleration_s = 0.0, deceleration_s = 0.0;
  double run_up_from_rad = 0.0;  ///< where the approach took it, before A
  /// The axis's zero its angles (and its pulses') are from: (d - it) / r2_m.
  std::optional<double> zero_displacement_m;
  std::string stage;  ///< approach, run_up, span, run_down, done, failed
  std::optional<double> position_rad;
  /// Over the span, once passed: (B - A) over the time between the readings
  /// that crossed A and B, the standard deviation of the velocity per drive
  /// period and over ten, the mean drive (frequency, amplitude).
  std::optional<double> measured_velocity_rad_per_s, ripple_rad_per_s, ripple_10_rad_per_s,
      mean_f_hz, mean_V;
  /// The LuGre model's mean velocity at the drive the board chose (its
  /// mean frequency and amplitude over the span), beside the measured one.
  std::optional<double> model_velocity_rad_per_s;
  struct Triggers {
    double start_rad = 0.0, step_rad = 0.0, width_s = 0.0, pre_start_rad = 0.0;
    std::uint64_t pulses = 0;  ///< asked for
    std::uint64_t fired = 0, late = 0, unreported = 0;
  };
  std::optional<Triggers> triggers;
  /// Every pulse fired, in k's order (in the run's summary only).
  std::optional<std::vector<TriggerPulse>> pulses;
  std::optional<firmware::MoveEnd> stop_cause;  ///< once it ended (on_target: done)
};

/// A finished run's account (in the `state` event, and in `status`).
struct RunSummary {
  firmware::StopCause cause = firmware::StopCause::none;
  OutputEnd output;
  LoopHealth drive, sensor;
  std::vector<std::string> realtime;
  struct Samples {
    std::uint64_t drive = 0, sensor = 0;
  } samples;
  /// How each axis of the run ended, in the run's order: its cause, its
  /// output and (a move's) its account. A run of one axis has one.
  struct Axis {
    std::string name;
    firmware::StopCause cause = firmware::StopCause::none;
    OutputEnd output;
    std::optional<MoveAccount> move;
    std::optional<ScanAccount> scan;
  };
  std::vector<Axis> axes;
  /// A calibration run's result: present in a calibration run's summary,
  /// nil when it installed none (calibration_error says why).
  wire::Keyed<CalibrationRecord> calibration;
  std::optional<std::string> calibration_error;
};

/// `start`'s reply, and the start of every run (`step`, `move_to` and
/// `calibrate` add their own).
struct StartReply {
  std::uint64_t run = 0;
  std::int64_t t0_ns = 0;  ///< the first drive deadline and the sawtooth's phase origin
  double lease_s = 0.0, duration_s = 0.0;
  std::optional<std::uint64_t> count;         ///< a step's periods
  std::optional<model::Direction> direction;  ///< a step's direction
  /// A move's: the request as the board took it (every field, and the
  /// coarse steps' waveform as used), the zero its target is from, and
  /// whether the calibration's step table is used.
  struct Move {
    std::string axis;
    bool calibrated = false;
    std::optional<double> zero_displacement_m;
    MoveToRequest request;
  };
  std::optional<std::vector<Move>> moves;         ///< a move's, one per axis it moves
  std::optional<std::vector<ScanAccount>> scans;  ///< a scan's, one per axis, as taken
  /// A calibration's: its V0, the frequencies it steps at, the steps per point.
  struct Calibration {
    std::uint32_t steps_per_point = 0;
    double V0 = 0.0;
    std::vector<double> f_hz;
  };
  std::optional<Calibration> calibration;
};

/// An axis at rest as the board's idle reading sees it (docs/protocol.md,
/// "At rest"): in `status.axes[].rest` and the `health` event's `rest`.
struct RestReport {
  std::string name;  ///< the axis
  /// From its zero: the mean of its latest 8 good readings (nil: none yet).
  std::optional<double> position_rad;
  std::optional<double> noise_m;    ///< one reading's noise at rest (nil: too few readings)
  std::optional<double> noise_rad;  ///< the same over its radius
  std::optional<double> age_s;      ///< since its latest good reading (nil: none yet)
  /// How far it moved at rest since this rest began (the board's start or
  /// its last run's end), and whether a move was reported in it.
  double moved_rad = 0.0;
  bool moved = false;
  std::uint64_t errors = 0;  ///< idle readings that failed in this rest
  /// Between runs, its sensor does not answer: its latest idle reading
  /// failed, or none came for 5 idle periods (a second at
  /// least). `position_rad` is then the last one known.
  bool stale = false;
};

/// The `moved` event: an axis moved at rest, by more than its noise allows.
struct MovedEvent {
  std::string board_id;
  std::int64_t board_ns = 0;
  std::string axis;
  double moved_m = 0.0;    ///< this move, at the sensor
  double moved_rad = 0.0;  ///< the same over the axis's radius
  RestReport rest;         ///< the axis as it now is
};

/// The `state` event: published at every change of state.
struct StateEvent {
  BoardState state = BoardState::idle;
  std::int64_t board_ns = 0;
  std::optional<std::uint64_t> run;
  std::optional<firmware::StopCause> fault;  ///< the latched cause, in state fault
  std::optional<RunSummary> summary;         ///< once the run `run` ended
};

/// The run in `status`: the one under way, or the last.
struct RunStatus {
  std::uint64_t id = 0;
  std::vector<std::string> axes;  ///< the axes it drives, in the run's order
  std::int64_t t0_ns = 0;
  double duration_s = 0.0, lease_s = 0.0;
  bool finished = false;
  LoopHealth drive, sensor;
  std::optional<RunSummary> summary;              ///< once finished
  std::optional<std::vector<MoveAccount>> moves;  ///< a move's progress, one per axis
  std::optional<std::vector<ScanAccount>> scans;  ///< a scan's progress, one per axis
  std::optional<double> calibration_progress;
};

/// `status.requests`' key for commands the board does not know.
inline constexpr const char* kUnknownCommands = "(unknown)";

/// `status`'s reply: the board's full snapshot.
struct Status {
  std::string board_id;  ///< as in hello
  BoardState state = BoardState::idle;
  std::int64_t board_ns = 0;
  bool controller = false;                   ///< the caller controls the rig
  bool controlled = false;                   ///< some client does
  std::optional<firmware::StopCause> fault;  ///< the board's latched fault (an axis's: `axes`)
  struct Span {
    std::uint64_t first = 0, next = 0;
  };
  struct Recorder {
    Span drive, sensor;
  } recorder;
  struct Position {
    std::optional<double> position_rad;  ///< the mean of the last good readings from the zero
    std::optional<double> zero_displacement_m;  ///< the axis's zero
  };
  std::optional<ConfigureRequest> configured;
  std::optional<RunStatus> run;
  /// Each axis's position from its zero, whether it is calibrated and its
  /// latched fault, in the board's order, one or several.
  struct Axis {
    std::string name;
    Position position;
    bool calibrated = false;
    /// Its own latched fault (an axis's fault latches on it alone, the
    /// others run on; `reset_fault` clears it), nil: none.
    std::optional<firmware::StopCause> fault;
    RestReport rest;  ///< what its readings at rest say
  };
  std::vector<Axis> axes;
  /// `requests`: how many of each command the board has had since it
  /// started (taken or refused; unknown ones under kUnknownCommands).
  std::map<std::string, std::uint64_t> requests;
};

/// `stop`'s, `estop`'s and `reset_fault`'s reply: the state they left.
struct StateReply {
  BoardState state = BoardState::idle;
};

/// `lease`'s reply.
struct LeaseReply {
  double lease_s = 0.0;
};

/// `zero`'s reply: the position from the new zero.
struct ZeroReply {
  Status::Position position;
};

/// `configure`'s reply: the values taken, and the rise fraction D = C_dr·e_dr.
struct ConfigureReply {
  double D = 0.0;
  ConfigureRequest configured;
};

/// `fetch`'s reply: a sample frame (MessagePack bin).
struct FetchReply {
  nlohmann::json frame;  ///< binary
};

/// `set_calibration`'s reply.
struct SetCalibrationReply {
  std::optional<CalibrationRecord> calibration;  ///< as installed (nil: cleared)
  std::optional<std::string> saved_to;           ///< the board's file, nil when none or it failed
  std::optional<std::string> save_error;         ///< why writing the file failed (only then)
};

/// The `health` event: about four a second.
struct HealthEvent {
  BoardState state = BoardState::idle;
  std::int64_t board_ns = 0;
  std::optional<LoopHealth> drive, sensor;        ///< while a run is under way
  std::optional<std::vector<MoveAccount>> moves;  ///< a move's progress, one per axis
  std::optional<std::vector<ScanAccount>> scans;  ///< a scan's progress, one per axis
  std::optional<double> calibration_progress;
  std::string board_id;          ///< as in hello: a follower sees a restart here
  std::vector<RestReport> rest;  ///< every axis at rest, in the board's order
};

void to_json(nlohmann::json& j, const Hello& m);
void from_json(const nlohmann::json& j, Hello& m);
void to_json(nlohmann::json& j, const LoopHealth& m);
void from_json(const nlohmann::json& j, LoopHealth& m);
void to_json(nlohmann::json& j, const ClockReply& m);
void from_json(const nlohmann::json& j, ClockReply& m);
void to_json(nlohmann::json& j, const ConfigureRequest& m);
void from_json(const nlohmann::json& j, ConfigureRequest& m);
void to_json(nlohmann::json& j, const StepRequest& m);
void from_json(const nlohmann::json& j, StepRequest& m);
void to_json(nlohmann::json& j, const MoveToRequest& m);
void from_json(const nlohmann::json& j, MoveToRequest& m);
void to_json(nlohmann::json& j, const OutputEnd& m);
void from_json(const nlohmann::json& j, OutputEnd& m);
void to_json(nlohmann::json& j, const RunSummary& m);
void from_json(const nlohmann::json& j, RunSummary& m);
void to_json(nlohmann::json& j, const StateEvent& m);
void from_json(const nlohmann::json& j, StateEvent& m);
void to_json(nlohmann::json& j, const RestReport& m);
void to_json(nlohmann::json& j, const ScanAccount& m);
void from_json(const nlohmann::json& j, ScanAccount& m);
void to_json(nlohmann::json& j, const TriggerEvent& m);
void from_json(const nlohmann::json& j, TriggerEvent& m);
void from_json(const nlohmann::json& j, RestReport& m);
void to_json(nlohmann::json& j, const MovedEvent& m);
void from_json(const nlohmann::json& j, MovedEvent& m);
void to_json(nlohmann::json& j, const HealthEvent& m);
void from_json(const nlohmann::json& j, HealthEvent& m);
void to_json(nlohmann::json& j, const RunStatus& m);
void from_json(const nlohmann::json& j, RunStatus& m);
void to_json(nlohmann::json& j, const Status& m);
void from_json(const nlohmann::json& j, Status& m);
void to_json(nlohmann::json& j, const CalibrationRecord& m);
void from_json(const nlohmann::json& j, CalibrationRecord& m);
void to_json(nlohmann::json& j, const StateReply& m);
void from_json(const nlohmann::json& j, StateReply& m);
void to_json(nlohmann::json& j, const LeaseReply& m);
void from_json(const nlohmann::json& j, LeaseReply& m);
void to_json(nlohmann::json& j, const ZeroReply& m);
void from_json(const nlohmann::json& j, ZeroReply& m);
void to_json(nlohmann::json& j, const ConfigureReply& m);
void from_json(const nlohmann::json& j, ConfigureReply& m);
void to_json(nlohmann::json& j, const FetchReply& m);
void from_json(const nlohmann::json& j, FetchReply& m);
void to_json(nlohmann::json& j, const SetCalibrationReply& m);
void from_json(const nlohmann::json& j, SetCalibrationReply& m);
void to_json(nlohmann::json& j, const MoveAccount& m);
void from_json(const nlohmann::json& j, MoveAccount& m);
void to_json(nlohmann::json& j, const StartReply& m);
void from_json(const nlohmann::json& j, StartReply& m);

/// Every key of the replies' and events' field lists (tests count them).
[[nodiscard]] std::vector<std::string_view> reply_keys();
/// Each reply's and event's own keys by the message's name, for the
/// board's dictionary (`describe`'s `messages`: [{name, always}]): a client
/// builds its checks from them.
[[nodiscard]] nlohmann::json message_fields();

/// Where a calibration breaks the ranges its field list declares (the
/// board's V_max and fastest frequency as the named limits), or nullopt.
[[nodiscard]] std::optional<wire::RangeBreach> check_calibration_ranges(const CalibrationRecord& c,
                                                                        double V_max,
                                                                        double f_max_hz);

/// Decodes `j` as a T, any failure a ProtocolError naming the field.
template <class T>
[[nodiscard]] T decode(const nlohmann::json& j) {
  if (!j.is_object()) throw ProtocolError(code::malformed, "", "not a map");
  return j.get<T>();
}

/// The requests whose arguments the docs' tables list, each by its command
/// (`kCommand`); a new command's request goes here.
using DocumentedRequests = std::tuple<ConfigureRequest, StartRequest, StepRequest, CalibrateRequest,
                                      ScanRequest, LeaseRequest, FetchRequest>;

// The enums the wire carries become their names wherever one is put into a
// JSON value (nlohmann would write the number otherwise).
void to_json(nlohmann::json& j, BoardState s);

}  // namespace piezo::protocol

namespace piezo::firmware {
void to_json(nlohmann::json& j, StopCause c);
void to_json(nlohmann::json& j, OutputState s);
}  // namespace piezo::firmware
