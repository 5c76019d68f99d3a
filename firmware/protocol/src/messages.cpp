#include "piezo/protocol/messages.hpp"

#include <fmt/format.h>

#include <type_traits>
#include <variant>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/wire_fields.hpp"

// The enums the wire carries by name, and each reply's and event's one
// field list: its encoder and decoder are generated from these
// (wire_fields.hpp), so each key is written here once.
namespace piezo::protocol::wire {

// The enums the wire carries by name: their name tables.
#define PIEZO_WIRE_NAMES(Enum, table_)           \
  template <>                                    \
  struct Names<Enum> {                           \
    static constexpr const auto& table = table_; \
  };
PIEZO_WIRE_NAMES(BoardState, kBoardStateNames)
PIEZO_WIRE_NAMES(firmware::StopCause, firmware::kStopCauseNames)
PIEZO_WIRE_NAMES(firmware::OutputState, firmware::kOutputStateNames)
PIEZO_WIRE_NAMES(firmware::MoveState, firmware::kMoveStateNames)
PIEZO_WIRE_NAMES(firmware::MoveEnd, firmware::kMoveEndNames)
PIEZO_WIRE_NAMES(model::Direction, model::kDirectionNames)
#undef PIEZO_WIRE_NAMES

template <>
struct Fields<CalibrationRecord::RestReadings> {
  using T = CalibrationRecord::RestReadings;
  static constexpr auto list =
      std::tuple{field("skipped", &T::skipped), field("averaged", &T::averaged)};
};
template <>
struct Fields<CalibrationRecord::Frequency> {
  using T = CalibrationRecord::Frequency;
  static constexpr auto list =
      std::tuple{field(wire_key::f_hz, &T::f_hz).within({1e-3, 1e9}, "Hz", wire_key::f_max_hz),
                 // Each a step per period in rad, one per step fraction.
                 field("forward_rad", &T::forward_rad).within({-1.0, 1.0}, "rad"),
                 field("reverse_rad", &T::reverse_rad).within({-1.0, 1.0}, "rad"),
                 field("reliable", &T::reliable, omitted_when_absent),
                 field("speed_rad_per_s", &T::speed_rad_per_s, omitted_when_absent)};
};
template <>
struct Fields<CalibrationRecord> {
  using T = CalibrationRecord;
  static constexpr auto list = std::tuple{
      field(wire_key::version, &T::version).within({T::kVersion, T::kVersion}, ""),
      field("created", &T::created, may_be_missing),
      field(firmware::arguments::V0.name, &T::V0).within({0.0, 1e9, true}, "V", wire_key::V_max),
      field(wire_key::D, &T::D).within({0.01, 0.99}, ""),
      field(wire_key::r2_m, &T::r2_m).within({1e-6, 10.0}, "m"),
      field(wire_key::steps_per_point, &T::steps_per_point).within({1.0, 1000.0}, "periods"),
      field("rest_readings", &T::rest_readings, omitted_when_absent),
      field(wire_key::step_fractions, &T::step_fractions, may_be_missing),
      field(wire_key::noise_m, &T::noise_m).within({0.0, 1e-2}, "m"),
      field("rad_per_V", &T::rad_per_V).within({1e-9, 1e-2}, "rad/V"),
      field(wire_key::frequencies, &T::frequencies),
      field(wire_key::model, &T::model, may_be_missing),
      field("step_floor_rad", &T::step_floor_rad, may_be_missing),
      field("fastest_f_hz", &T::fastest_f_hz, may_be_missing),
      field(wire_key::noise_rad, &T::noise_rad, may_be_missing),
      field("resolution_rad", &T::resolution_rad, may_be_missing),
      field("smallest_tolerance_rad", &T::smallest_tolerance_rad, may_be_missing)};
};

template <>
struct Fields<Hello::Backends> {
  using T = Hello::Backends;
  static constexpr auto list = std::tuple{field("lines", &T::lines)};
};
template <>
struct Fields<Hello::Limits> {
  using T = Hello::Limits;
  static constexpr auto list = std::tuple{field(wire_key::V_min, &T::V_min),
                                          field(wire_key::V_max, &T::V_max),
                                          field(wire_key::slew_V_per_s, &T::slew_V_per_s),
                                          field("ramp_down_V_per_s", &T::ramp_down_V_per_s),
                                          field("sensor_stale_s", &T::sensor_stale_s),
                                          field(wire_key::f_max_hz, &T::f_max_hz),
                                          field(wire_key::duration_max_s, &T::duration_max_s),
                                          field(wire_key::lease_max_s, &T::lease_max_s)};
};
template <>
struct Fields<AxisInfo> {
  using T = AxisInfo;
  static constexpr auto list =
      std::tuple{field(wire_key::name, &T::name),
                 field(wire_key::r2_m, &T::r2_m),
                 field(wire_key::V_min, &T::V_min),
                 field(wire_key::V_max, &T::V_max),
                 field(wire_key::slew_V_per_s, &T::slew_V_per_s),
                 field("travel_min_rad", &T::travel_min_rad),
                 field("travel_max_rad", &T::travel_max_rad),
                 field(wire_key::drive, &T::drive),
                 field(wire_key::sensor, &T::sensor),
                 field(wire_key::zero_displacement_m, &T::zero_displacement_m),
                 field(wire_key::calibration, &T::calibration),
                 field("velocity_max_rad_per_s", &T::velocity_max_rad_per_s, may_be_missing),
                 field("base_rate_rad_per_s", &T::base_rate_rad_per_s, may_be_missing),
                 field(wire_key::trigger, &T::trigger, may_be_missing)};
};
template <>
struct Fields<Hello> {
  using T = Hello;
  static constexpr auto list = std::tuple{field(wire_key::protocol, &T::protocol),
                                          field(wire_key::board_id, &T::board_id, may_be_missing),
                                          field("frame_version", &T::frame_version),
                                          field("daemon", &T::daemon),
                                          field(wire_key::stream, &T::stream),
                                          field(wire_key::clock, &T::clock),
                                          field("backends", &T::backends),
                                          field("limits", &T::limits),
                                          field("drive_rate_hz", &T::drive_rate_hz),
                                          field("sensor_rate_hz", &T::sensor_rate_hz),
                                          field("output_latency_s", &T::output_latency_s),
                                          field(wire_key::lease_s, &T::lease_s),
                                          field("recorder_s", &T::recorder_s),
                                          field(wire_key::axes, &T::axes)};
};
template <>
struct Fields<LoopHealth::Timing> {
  using T = LoopHealth::Timing;
  static constexpr auto list = std::tuple{
      field("p50_us", &T::p50_us), field("p99_us", &T::p99_us), field("max_us", &T::max_us),
      field("mean_us", &T::mean_us), field(wire_key::histogram_us, &T::histogram_us)};
};
template <>
struct Fields<LoopHealth> {
  using T = LoopHealth;
  static constexpr auto list = std::tuple{field("cycles", &T::cycles),
                                          field("overruns", &T::overruns),
                                          field("missed_cycles", &T::missed_cycles),
                                          field("dropped", &T::dropped),
                                          field(wire_key::errors, &T::errors),
                                          inline_fields(&T::timing)};
};
template <>
struct Fields<ClockReply> {
  static constexpr auto list = std::tuple{field(wire_key::board_ns, &ClockReply::board_ns)};
};
template <>
struct Fields<OutputEnd> {
  using T = OutputEnd;
  static constexpr auto list =
      std::tuple{field(wire_key::state, &T::state),
                 field("zero_confirmed", &T::zero_confirmed),
                 field("zero_read_back", &T::zero_read_back, may_be_missing),
                 field("acknowledged_V", &T::acknowledged_V),
                 field("zero_writes", &T::zero_writes),
                 field("zero_status", &T::zero_status, may_be_missing),
                 field("enabled_ever", &T::enabled_ever, may_be_missing),
                 field("enable_status", &T::enable_status)};
};
template <>
struct Fields<MoveAccount::Hold> {
  using T = MoveAccount::Hold;
  static constexpr auto list = std::tuple{field(wire_key::hold_s, &T::hold_s),
                                          field("hold_rms_error_rad", &T::hold_rms_error_rad),
                                          field("hold_max_error_rad", &T::hold_max_error_rad)};
};
template <>
struct Fields<MoveAccount> {
  using T = MoveAccount;
  static constexpr auto list =
      std::tuple{field(wire_key::axis, &T::axis, may_be_missing),
                 field(wire_key::state, &T::state),
                 field(wire_key::target_rad, &T::target_rad),
                 field(wire_key::tolerance_rad, &T::tolerance_rad),
                 field(wire_key::position_rad, &T::position_rad),
                 field("error_rad", &T::error_rad),
                 field("on_target", &T::on_target),
                 field("on_target_at_s", &T::on_target_at_s),
                 field("steps", &T::steps),
                 field(wire_key::f_hz, &T::f_hz),
                 field(wire_key::noise_m, &T::noise_m),
                 inline_fields(&T::hold),
                 field(wire_key::stop_cause, &T::stop_cause, omitted_when_absent)};
};
template <>
struct Fields<TriggerPulse> {
  using T = TriggerPulse;
  static constexpr auto list = std::tuple{field(wire_key::k, &T::k),
                                          field(wire_key::position_rad, &T::position_rad),
                                          field(wire_key::angle_rad, &T::angle_rad),
                                          field("reading_s", &T::reading_s),
                                          field("edge_s", &T::edge_s),
                                          field(wire_key::late, &T::late)};
};
template <>
struct Fields<TriggerEvent> {
  using T = TriggerEvent;
  static constexpr auto list =
      std::tuple{field(wire_key::board_id, &T::board_id), field(wire_key::run, &T::run),
                 field(wire_key::axis, &T::axis), inline_fields(&T::pulse)};
};
template <>
struct Fields<ScanAccount::Triggers> {
  using T = ScanAccount::Triggers;
  static constexpr auto list =
      std::tuple{field("start_rad", &T::start_rad),   field("step_rad", &T::step_rad),
                 field("width_s", &T::width_s),       field("pre_start_rad", &T::pre_start_rad),
                 field(wire_key::pulses, &T::pulses), field("fired", &T::fired),
                 field(wire_key::late, &T::late),     field("unreported", &T::unreported)};
};
template <>
struct Fields<ScanAccount> {
  using T = ScanAccount;
  static constexpr auto list =
      std::tuple{field(wire_key::axis, &T::axis),
                 field(wire_key::from_rad, &T::from_rad),
                 field(wire_key::to_rad, &T::to_rad),
                 field(wire_key::velocity_rad_per_s, &T::velocity_rad_per_s),
                 field(firmware::arguments::acceleration_s.name, &T::acceleration_s),
                 field(firmware::arguments::deceleration_s.name, &T::deceleration_s),
                 field("run_up_from_rad", &T::run_up_from_rad),
                 field(wire_key::zero_displacement_m, &T::zero_displacement_m),
                 field("stage", &T::stage),
                 field(wire_key::position_rad, &T::position_rad),
                 field("measured_velocity_rad_per_s", &T::measured_velocity_rad_per_s),
                 field("ripple_rad_per_s", &T::ripple_rad_per_s),
                 field("ripple_10_rad_per_s", &T::ripple_10_rad_per_s),
                 field("mean_f_hz", &T::mean_f_hz),
                 field("mean_V", &T::mean_V),
                 field("model_velocity_rad_per_s", &T::model_velocity_rad_per_s),
                 field(wire_key::triggers, &T::triggers),
                 field(wire_key::pulses, &T::pulses, omitted_when_absent),
                 field(wire_key::stop_cause, &T::stop_cause, omitted_when_absent)};
};
template <>
struct Fields<RunSummary::Samples> {
  using T = RunSummary::Samples;
  static constexpr auto list =
      std::tuple{field(wire_key::drive, &T::drive), field(wire_key::sensor, &T::sensor)};
};
template <>
struct Fields<RunSummary::Axis> {
  using T = RunSummary::Axis;
  static constexpr auto list = std::tuple{
      field(wire_key::name, &T::name), field(wire_key::cause, &T::cause),
      field(wire_key::output, &T::output), field(wire_key::move, &T::move, omitted_when_absent),
      field(wire_key::scan, &T::scan, omitted_when_absent)};
};
template <>
struct Fields<RunSummary> {
  using T = RunSummary;
  static constexpr auto list =
      std::tuple{field(wire_key::cause, &T::cause),
                 field(wire_key::output, &T::output),
                 field(wire_key::drive, &T::drive),
                 field(wire_key::sensor, &T::sensor),
                 field("realtime", &T::realtime, may_be_missing),
                 field("samples", &T::samples),
                 field(wire_key::axes, &T::axes),
                 field(wire_key::calibration, &T::calibration, omitted_when_absent),
                 field("calibration_error", &T::calibration_error, omitted_when_absent)};
};
template <>
struct Fields<StartReply::Move> {
  using T = StartReply::Move;
  static constexpr auto list = std::tuple{
      field(wire_key::axis, &T::axis), field(wire_key::calibrated, &T::calibrated),
      field(wire_key::zero_displacement_m, &T::zero_displacement_m), inline_fields(&T::request)};
};
template <>
struct Fields<StartReply::Calibration> {
  using T = StartReply::Calibration;
  static constexpr auto list =
      std::tuple{field(wire_key::steps_per_point, &T::steps_per_point),
                 field(firmware::arguments::V0.name, &T::V0), field(wire_key::f_hz, &T::f_hz)};
};
template <>
struct Fields<StartReply> {
  using T = StartReply;
  static constexpr auto list =
      std::tuple{field(wire_key::run, &T::run),
                 field(wire_key::t0_ns, &T::t0_ns),
                 field(firmware::arguments::lease_s.name, &T::lease_s),
                 field(firmware::arguments::duration_s.name, &T::duration_s),
                 field(firmware::arguments::count.name, &T::count, omitted_when_absent),
                 field(firmware::arguments::direction.name, &T::direction, omitted_when_absent),
                 field(wire_key::moves, &T::moves, omitted_when_absent),
                 field(wire_key::scans, &T::scans, omitted_when_absent),
                 inline_fields(&T::calibration)};
};
template <>
struct Fields<RestReport> {
  using T = RestReport;
  static constexpr auto list = std::tuple{field(wire_key::name, &T::name),
                                          field(wire_key::position_rad, &T::position_rad),
                                          field(wire_key::noise_m, &T::noise_m),
                                          field(wire_key::noise_rad, &T::noise_rad),
                                          field("age_s", &T::age_s),
                                          field(wire_key::moved_rad, &T::moved_rad),
                                          field(wire_key::moved, &T::moved),
                                          field(wire_key::errors, &T::errors),
                                          field("stale", &T::stale)};
};
template <>
struct Fields<MovedEvent> {
  using T = MovedEvent;
  static constexpr auto list =
      std::tuple{field(wire_key::board_id, &T::board_id),   field(wire_key::board_ns, &T::board_ns),
                 field(wire_key::axis, &T::axis),           field("moved_m", &T::moved_m),
                 field(wire_key::moved_rad, &T::moved_rad), field(wire_key::rest, &T::rest)};
};
template <>
struct Fields<StateEvent> {
  using T = StateEvent;
  static constexpr auto list =
      std::tuple{field(wire_key::state, &T::state), field(wire_key::board_ns, &T::board_ns),
                 field(wire_key::run, &T::run), field(wire_key::fault, &T::fault),
                 field(wire_key::summary, &T::summary, omitted_when_absent)};
};
template <>
struct Fields<HealthEvent> {
  using T = HealthEvent;
  static constexpr auto list = std::tuple{
      field(wire_key::board_id, &T::board_id, may_be_missing),
      field(wire_key::state, &T::state),
      field(wire_key::board_ns, &T::board_ns),
      field(wire_key::drive, &T::drive, omitted_when_absent),
      field(wire_key::sensor, &T::sensor, omitted_when_absent),
      field(wire_key::moves, &T::moves, omitted_when_absent),
      field(wire_key::scans, &T::scans, omitted_when_absent),
      field(wire_key::calibration_progress, &T::calibration_progress, omitted_when_absent),
      field(wire_key::rest, &T::rest, may_be_missing)};
};
template <>
struct Fields<RunStatus> {
  using T = RunStatus;
  static constexpr auto list = std::tuple{
      field(wire_key::id, &T::id),
      field(wire_key::axes, &T::axes),
      field(wire_key::t0_ns, &T::t0_ns),
      field(firmware::arguments::duration_s.name, &T::duration_s),
      field(firmware::arguments::lease_s.name, &T::lease_s),
      field("finished", &T::finished),
      field(wire_key::drive, &T::drive),
      field(wire_key::sensor, &T::sensor),
      field(wire_key::summary, &T::summary, omitted_when_absent),
      field(wire_key::moves, &T::moves, omitted_when_absent),
      field(wire_key::scans, &T::scans, omitted_when_absent),
      field(wire_key::calibration_progress, &T::calibration_progress, omitted_when_absent)};
};
template <>
struct Fields<Status::Span> {
  using T = Status::Span;
  static constexpr auto list =
      std::tuple{field(wire_key::first, &T::first), field("next", &T::next)};
};
template <>
struct Fields<Status::Recorder> {
  using T = Status::Recorder;
  static constexpr auto list =
      std::tuple{field(wire_key::drive, &T::drive), field(wire_key::sensor, &T::sensor)};
};
template <>
struct Fields<Status::Position> {
  using T = Status::Position;
  static constexpr auto list =
      std::tuple{field(wire_key::position_rad, &T::position_rad),
                 field(wire_key::zero_displacement_m, &T::zero_displacement_m)};
};
template <>
struct Fields<Status::Axis> {
  using T = Status::Axis;
  static constexpr auto list =
      std::tuple{field(wire_key::name, &T::name), field(wire_key::position, &T::position),
                 field(wire_key::calibrated, &T::calibrated),
                 field(wire_key::fault, &T::fault, may_be_missing),
                 field(wire_key::rest, &T::rest, may_be_missing)};
};
template <>
struct Fields<Status> {
  using T = Status;
  static constexpr auto list = std::tuple{field(wire_key::board_id, &T::board_id, may_be_missing),
                                          field(wire_key::state, &T::state),
                                          field(wire_key::board_ns, &T::board_ns),
                                          field(wire_key::controller, &T::controller),
                                          field("controlled", &T::controlled),
                                          field(wire_key::fault, &T::fault),
                                          field("recorder", &T::recorder),
                                          field("configured", &T::configured, omitted_when_absent),
                                          field(wire_key::run, &T::run, omitted_when_absent),
                                          field("requests", &T::requests, may_be_missing),
                                          field(wire_key::axes, &T::axes)};
};

template <>
struct Fields<StateReply> {
  static constexpr auto list = std::tuple{field(wire_key::state, &StateReply::state)};
};
template <>
struct Fields<LeaseReply> {
  static constexpr auto list =
      std::tuple{field(firmware::arguments::lease_s.name, &LeaseReply::lease_s)};
};
template <>
struct Fields<ZeroReply> {
  static constexpr auto list = std::tuple{field(wire_key::position, &ZeroReply::position)};
};
template <>
struct Fields<ConfigureReply> {
  using T = ConfigureReply;
  static constexpr auto list = std::tuple{field(wire_key::D, &T::D), inline_fields(&T::configured)};
};
template <>
struct Fields<FetchReply> {
  static constexpr auto list = std::tuple{field("frame", &FetchReply::frame)};
};
template <>
struct Fields<SetCalibrationReply> {
  using T = SetCalibrationReply;
  static constexpr auto list =
      std::tuple{field(wire_key::calibration, &T::calibration), field("saved_to", &T::saved_to),
                 field("save_error", &T::save_error, omitted_when_absent)};
};

}  // namespace piezo::protocol::wire

namespace piezo::protocol {
namespace {

using nlohmann::json;

/// An optional argument: absent or nil is none.
std::optional<double> optional_number_arg(const json& args, std::string_view name) {
  const std::string key(name);
  const auto it = args.find(key);
  if (it == args.end() || it->is_null()) return std::nullopt;
  return number_arg(args, key);
}

/// Writes an optional argument only when it is given.
template <class T>
void put_if(json& j, std::string_view key, const std::optional<T>& v) {
  if (v) j[std::string(key)] = *v;
}

/// A request's waveform: V0 and f required, the rest defaulted as the
/// protocol documents.
model::DriveParameters drive_args(const json& args) {
  namespace a = firmware::arguments;
  model::DriveParameters d;
  d.V0 = number_arg(args, std::string(a::V0.name));
  d.f = number_arg(args, std::string(a::f.name));
  d.C_dr = number_arg(args, std::string(a::C_dr.name), d.C_dr);
  d.e_dr = number_arg(args, std::string(a::e_dr.name), d.e_dr);
  const std::string key(a::direction.name);
  const std::string direction = string_arg(args, key, std::string(model::name(d.direction)));
  if (const auto dir = model::parse_direction(direction)) {
    d.direction = *dir;
  } else {
    throw ProtocolError(
        code::bad_argument, key,
        fmt::format("{}: \"{}\"; allowed: {}", key, direction, model::kDirectionNames.list()));
  }
  return d;
}

json drive_json(const model::DriveParameters& d) {
  namespace a = firmware::arguments;
  return {{a::V0.name, d.V0},
          {a::f.name, d.f},
          {a::C_dr.name, d.C_dr},
          {a::e_dr.name, d.e_dr},
          {a::direction.name, model::name(d.direction)}};
}

}  // namespace

// Each reply's and event's codec: its field list's encoder and decoder.
#define PIEZO_FIELD_LIST_CODEC(T)       \
  void to_json(json& j, const T& m) {   \
    j = wire::encode(m);                \
  }                                     \
  void from_json(const json& j, T& m) { \
    wire::decode_into(j, m);            \
  }
PIEZO_FIELD_LIST_CODEC(CalibrationRecord)
PIEZO_FIELD_LIST_CODEC(StateReply)
PIEZO_FIELD_LIST_CODEC(LeaseReply)
PIEZO_FIELD_LIST_CODEC(ZeroReply)
PIEZO_FIELD_LIST_CODEC(ConfigureReply)
PIEZO_FIELD_LIST_CODEC(FetchReply)
PIEZO_FIELD_LIST_CODEC(SetCalibrationReply)
PIEZO_FIELD_LIST_CODEC(Hello)
PIEZO_FIELD_LIST_CODEC(LoopHealth)
PIEZO_FIELD_LIST_CODEC(ClockReply)
PIEZO_FIELD_LIST_CODEC(OutputEnd)
PIEZO_FIELD_LIST_CODEC(MoveAccount)
PIEZO_FIELD_LIST_CODEC(RunSummary)
PIEZO_FIELD_LIST_CODEC(StartReply)
PIEZO_FIELD_LIST_CODEC(RestReport)
PIEZO_FIELD_LIST_CODEC(MovedEvent)
PIEZO_FIELD_LIST_CODEC(ScanAccount)
PIEZO_FIELD_LIST_CODEC(TriggerEvent)
PIEZO_FIELD_LIST_CODEC(StateEvent)
PIEZO_FIELD_LIST_CODEC(HealthEvent)
PIEZO_FIELD_LIST_CODEC(RunStatus)
PIEZO_FIELD_LIST_CODEC(Status)
#undef PIEZO_FIELD_LIST_CODEC

void to_json(json& j, const ConfigureRequest& m) {
  j = drive_json(m.drive);
  j[std::string(firmware::arguments::duration_s.name)] = m.duration_s;
}

void from_json(const json& j, ConfigureRequest& m) {
  m.drive = drive_args(j);
  m.duration_s = number_arg(j, std::string(firmware::arguments::duration_s.name));
}

void to_json(json& j, const StepRequest& m) {
  j = drive_json(m.drive);
  j[std::string(firmware::arguments::count.name)] = m.count;
  put_if(j, firmware::arguments::lease_s.name, m.lease_s);
}

void from_json(const json& j, StepRequest& m) {
  m.count = uint_arg(j, std::string(firmware::arguments::count.name));
  m.drive = drive_args(j);
  m.lease_s = optional_number_arg(j, firmware::arguments::lease_s.name);
}

void to_json(json& j, const MoveToRequest& m) {
  j = json::object();
  for (const firmware::MoveField& field : firmware::kMoveFields) {
    const std::string key(field.name);
    std::visit(
        [&](auto member) {
          const auto& value = m.move.*member;
          if constexpr (std::is_same_v<std::remove_cvref_t<decltype(value)>, firmware::Approach>) {
            j[key] = firmware::kApproachNames.name(value);
          } else {
            j[key] = value;
          }
        },
        field.member);
  }
  put_if(j, firmware::arguments::V0.name, m.V0);
  put_if(j, firmware::arguments::f.name, m.f);
  put_if(j, firmware::arguments::C_dr.name, m.C_dr);
  put_if(j, firmware::arguments::e_dr.name, m.e_dr);
  put_if(j, firmware::arguments::lease_s.name, m.lease_s);
}

void from_json(const json& j, MoveToRequest& m) {
  static const firmware::MoveRequest defaults;
  for (const firmware::MoveField& field : firmware::kMoveFields) {
    const std::string key(field.name);
    std::visit(
        [&](auto member) {
          using T = std::remove_cvref_t<decltype(m.move.*member)>;
          const auto fallback = [&] {
            return field.required ? std::nullopt : std::optional<T>(defaults.*member);
          };
          if constexpr (std::is_same_v<T, double>) {
            m.move.*member = number_arg(j, key, fallback());
          } else if constexpr (std::is_same_v<T, std::uint64_t>) {
            m.move.*member = uint_arg(j, key, fallback());
          } else if constexpr (std::is_same_v<T, bool>) {
            m.move.*member = bool_arg(j, key, fallback());
          } else {
            const auto& names = firmware::kApproachNames;
            const std::string text = string_arg(j, key, std::string(names.name(defaults.*member)));
            const auto value = names.parse(text);
            if (!value) {
              throw ProtocolError(code::bad_argument, key,
                                  fmt::format("{}: \"{}\"; allowed: {}", key, text, names.list()));
            }
            m.move.*member = *value;
          }
        },
        field.member);
  }
  m.V0 = optional_number_arg(j, firmware::arguments::V0.name);
  m.f = optional_number_arg(j, firmware::arguments::f.name);
  m.C_dr = optional_number_arg(j, firmware::arguments::C_dr.name);
  m.e_dr = optional_number_arg(j, firmware::arguments::e_dr.name);
  m.lease_s = optional_number_arg(j, firmware::arguments::lease_s.name);
}

std::optional<wire::RangeBreach> check_calibration_ranges(const CalibrationRecord& c, double V_max,
                                                          double f_max_hz) {
  return wire::check_ranges(
      c, [&](std::string_view limit) { return limit == wire_key::V_max ? V_max : f_max_hz; });
}

std::vector<std::string_view> reply_keys() {
  std::vector<std::string_view> keys;
  const auto add = [&](std::string_view key) { keys.push_back(key); };
  wire::for_each_key<CalibrationRecord>(add);
  wire::for_each_key<StateReply>(add);
  wire::for_each_key<LeaseReply>(add);
  wire::for_each_key<ZeroReply>(add);
  wire::for_each_key<ConfigureReply>(add);
  wire::for_each_key<FetchReply>(add);
  wire::for_each_key<SetCalibrationReply>(add);
  wire::for_each_key<Hello>(add);
  wire::for_each_key<LoopHealth>(add);
  wire::for_each_key<ClockReply>(add);
  wire::for_each_key<OutputEnd>(add);
  wire::for_each_key<MoveAccount>(add);
  wire::for_each_key<RunSummary>(add);
  wire::for_each_key<StartReply>(add);
  wire::for_each_key<RestReport>(add);
  wire::for_each_key<MovedEvent>(add);
  wire::for_each_key<ScanAccount>(add);
  wire::for_each_key<TriggerEvent>(add);
  wire::for_each_key<StateEvent>(add);
  wire::for_each_key<HealthEvent>(add);
  wire::for_each_key<RunStatus>(add);
  wire::for_each_key<Status>(add);
  return keys;
}

json message_fields() {
  json out;
  const auto own = [&]<class T>(std::string_view name, std::type_identity<T>) {
    json keys = json::array();
    wire::for_each_own_key<T>([&](std::string_view key, bool always) {
      keys.push_back({{wire_key::name, key}, {"always", always}});
    });
    out[std::string(name)] = std::move(keys);
  };
  own("hello", std::type_identity<Hello>{});
  own("axis_info", std::type_identity<AxisInfo>{});
  own(wire_key::calibration, std::type_identity<CalibrationRecord>{});
  own("status", std::type_identity<Status>{});
  own("status_axis", std::type_identity<Status::Axis>{});
  own(wire_key::position, std::type_identity<Status::Position>{});
  own("run_status", std::type_identity<RunStatus>{});
  own(wire_key::rest, std::type_identity<RestReport>{});
  own("start", std::type_identity<StartReply>{});
  own(wire_key::move, std::type_identity<MoveAccount>{});
  own(wire_key::summary, std::type_identity<RunSummary>{});
  own("loop_health", std::type_identity<LoopHealth>{});
  own("state_reply", std::type_identity<StateReply>{});
  own("zero", std::type_identity<ZeroReply>{});
  own(wire_key::clock, std::type_identity<ClockReply>{});
  own(wire_key::state, std::type_identity<StateEvent>{});
  own("health", std::type_identity<HealthEvent>{});
  own(wire_key::moved, std::type_identity<MovedEvent>{});
  own(wire_key::scan, std::type_identity<ScanAccount>{});
  own(wire_key::trigger, std::type_identity<TriggerEvent>{});
  return out;
}

void to_json(json& j, BoardState s) {
  j = to_string(s);
}

}  // namespace piezo::protocol

namespace piezo::firmware {
void to_json(nlohmann::json& j, StopCause c) {
  j = to_string(c);
}
void to_json(nlohmann::json& j, OutputState s) {
  j = to_string(s);
}
}  // namespace piezo::firmware
