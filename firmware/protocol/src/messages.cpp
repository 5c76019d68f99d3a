#include "piezo/protocol/messages.hpp"

#include <fmt/format.h>

#include <type_traits>
#include <variant>

#include "piezo/protocol/error.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::protocol {
namespace {

using nlohmann::json;

/// A field of a reply or event; a missing or mistyped one is malformed.
template <class T>
T field(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || it->is_null()) {
    throw ProtocolError(code::malformed, key, fmt::format("{}: missing", key));
  }
  try {
    return it->get<T>();
  } catch (const json::exception&) {
    throw ProtocolError(code::malformed, key,
                        fmt::format("{}: of the wrong type ({})", key, it->type_name()));
  }
}

template <class T>
std::optional<T> optional_field(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  return field<T>(j, key);
}

json object_field(const json& j, const char* key) {
  const json v = j.value(key, json());
  if (!v.is_null() && !v.is_object()) {
    throw ProtocolError(code::malformed, key, fmt::format("{}: not a map", key));
  }
  return v.is_null() ? json::object() : v;
}

template <class T>
json nil_or(const std::optional<T>& v) {
  return v ? json(*v) : json(nullptr);
}

/// A field holding one of an enum's names (its name table's); a name the
/// table lacks is malformed, naming the field and the names allowed.
template <class E, std::size_t N>
E named_field(const json& j, const char* key, const NameTable<E, N>& table) {
  const auto text = field<std::string>(j, key);
  if (const auto value = table.parse(text)) return *value;
  throw ProtocolError(code::malformed, key,
                      fmt::format("{}: \"{}\"; allowed: {}", key, text, table.list()));
}

template <class E, std::size_t N>
std::optional<E> optional_named_field(const json& j, const char* key,
                                      const NameTable<E, N>& table) {
  const auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  return named_field(j, key, table);
}

/// An optional cause by its name, nil when absent.
json nil_or(const std::optional<firmware::StopCause>& cause) {
  return cause ? json(firmware::to_string(*cause)) : json(nullptr);
}

/// An optional argument: absent or nil is none.
std::optional<double> optional_number_arg(const json& args, const char* key) {
  const auto it = args.find(key);
  if (it == args.end() || it->is_null()) return std::nullopt;
  return number_arg(args, key);
}
std::optional<std::uint64_t> optional_uint_arg(const json& args, const char* key) {
  const auto it = args.find(key);
  if (it == args.end() || it->is_null()) return std::nullopt;
  return uint_arg(args, key);
}

/// Writes an optional argument only when it is given.
template <class T>
void put_if(json& j, const char* key, const std::optional<T>& v) {
  if (v) j[key] = *v;
}

/// A request's waveform: V0 and f required, the rest defaulted as the
/// protocol documents.
model::DriveParameters drive_args(const json& args) {
  model::DriveParameters d;
  d.V0 = number_arg(args, "V0");
  d.f = number_arg(args, "f");
  d.C_dr = number_arg(args, "C_dr", d.C_dr);
  d.e_dr = number_arg(args, "e_dr", d.e_dr);
  const std::string direction = string_arg(args, "direction", "forward");
  if (const auto dir = model::parse_direction(direction)) {
    d.direction = *dir;
  } else {
    throw ProtocolError(
        code::bad_argument, "direction",
        fmt::format("direction: \"{}\"; allowed: {}", direction, model::kDirectionNames.list()));
  }
  return d;
}

json drive_json(const model::DriveParameters& d) {
  return {{"V0", d.V0},
          {"f", d.f},
          {"C_dr", d.C_dr},
          {"e_dr", d.e_dr},
          {"direction", model::name(d.direction)}};
}

}  // namespace

void to_json(json& j, const Hello& m) {
  const auto& l = m.limits;
  j = {{"protocol", m.protocol},
       {"frame_version", m.frame_version},
       {"daemon", m.daemon},
       {"stream", m.stream},
       {"clock", m.clock},
       {"backends",
        {{"drive", m.backends.drive}, {"sensor", m.backends.sensor}, {"lines", m.backends.lines}}},
       {"limits",
        {{"V_min", l.V_min},
         {"V_max", l.V_max},
         {"slew_V_per_s", l.slew_V_per_s},
         {"ramp_down_V_per_s", l.ramp_down_V_per_s},
         {"sensor_stale_s", l.sensor_stale_s},
         {"f_max_hz", l.f_max_hz},
         {"duration_max_s", l.duration_max_s},
         {"lease_max_s", l.lease_max_s}}},
       {"sensor", {{"r2_m", m.sensor_r2_m}, {"zero_displacement_m", nil_or(m.sensor_zero_m)}}},
       {"drive_rate_hz", m.drive_rate_hz},
       {"sensor_rate_hz", m.sensor_rate_hz},
       {"output_latency_s", m.output_latency_s},
       {"lease_s", m.lease_s},
       {"recorder_s", m.recorder_s},
       {"calibration", m.calibration}};
}

void from_json(const json& j, Hello& m) {
  m.protocol = field<std::uint32_t>(j, "protocol");
  m.frame_version = field<std::uint32_t>(j, "frame_version");
  m.daemon = field<std::string>(j, "daemon");
  m.stream = field<std::string>(j, "stream");
  m.clock = field<std::string>(j, "clock");
  const json b = object_field(j, "backends");
  m.backends = {field<std::string>(b, "drive"), field<std::string>(b, "sensor"),
                field<std::string>(b, "lines")};
  const json l = object_field(j, "limits");
  m.limits = {field<double>(l, "V_min"),          field<double>(l, "V_max"),
              field<double>(l, "slew_V_per_s"),   field<double>(l, "ramp_down_V_per_s"),
              field<double>(l, "sensor_stale_s"), field<double>(l, "f_max_hz"),
              field<double>(l, "duration_max_s"), field<double>(l, "lease_max_s")};
  const json sensor = object_field(j, "sensor");
  m.sensor_r2_m = field<double>(sensor, "r2_m");
  m.sensor_zero_m = optional_field<double>(sensor, "zero_displacement_m");
  m.drive_rate_hz = field<double>(j, "drive_rate_hz");
  m.sensor_rate_hz = field<double>(j, "sensor_rate_hz");
  m.output_latency_s = field<double>(j, "output_latency_s");
  m.lease_s = field<double>(j, "lease_s");
  m.recorder_s = field<double>(j, "recorder_s");
  m.calibration = j.value("calibration", json());
}

void to_json(json& j, const LoopHealth& m) {
  j = {{"cycles", m.cycles},
       {"overruns", m.overruns},
       {"missed_cycles", m.missed_cycles},
       {"dropped", m.dropped},
       {"errors", m.errors}};
  if (m.timing) {
    j["p50_us"] = m.timing->p50_us;
    j["p99_us"] = m.timing->p99_us;
    j["max_us"] = m.timing->max_us;
    j["mean_us"] = m.timing->mean_us;
    j["histogram_us"] = m.timing->histogram_us;
  }
}

void from_json(const json& j, LoopHealth& m) {
  m.cycles = field<std::uint64_t>(j, "cycles");
  m.overruns = field<std::uint64_t>(j, "overruns");
  m.missed_cycles = field<std::uint64_t>(j, "missed_cycles");
  m.dropped = field<std::uint64_t>(j, "dropped");
  m.errors = field<std::uint64_t>(j, "errors");
  m.timing.reset();
  if (j.contains("p50_us")) {
    m.timing = LoopHealth::Timing{field<double>(j, "p50_us"), field<double>(j, "p99_us"),
                                  field<double>(j, "max_us"), field<double>(j, "mean_us"),
                                  field<std::vector<double>>(j, "histogram_us")};
  }
}

void to_json(json& j, const ClockReply& m) {
  j = {{"board_ns", m.board_ns}};
}

void from_json(const json& j, ClockReply& m) {
  m.board_ns = field<std::int64_t>(j, "board_ns");
}

void to_json(json& j, const ConfigureRequest& m) {
  j = drive_json(m.drive);
  j["duration_s"] = m.duration_s;
}

void from_json(const json& j, ConfigureRequest& m) {
  m.drive = drive_args(j);
  m.duration_s = number_arg(j, "duration_s");
}

void to_json(json& j, const StartRequest& m) {
  j = json::object();
  put_if(j, "lease_s", m.lease_s);
}

void from_json(const json& j, StartRequest& m) {
  m.lease_s = optional_number_arg(j, "lease_s");
}

void to_json(json& j, const StepRequest& m) {
  j = drive_json(m.drive);
  j["count"] = m.count;
  put_if(j, "lease_s", m.lease_s);
}

void from_json(const json& j, StepRequest& m) {
  m.count = uint_arg(j, "count");
  m.drive = drive_args(j);
  m.lease_s = optional_number_arg(j, "lease_s");
}

void to_json(json& j, const CalibrateRequest& m) {
  j = json::object();
  put_if(j, "V0", m.V0);
  put_if(j, "lease_s", m.lease_s);
}

void from_json(const json& j, CalibrateRequest& m) {
  m.V0 = optional_number_arg(j, "V0");
  m.lease_s = optional_number_arg(j, "lease_s");
}

void to_json(json& j, const LeaseRequest& m) {
  j = json::object();
  put_if(j, "drive_received", m.drive_received);
}

void from_json(const json& j, LeaseRequest& m) {
  m.drive_received = optional_uint_arg(j, "drive_received");
}

void to_json(json& j, const FetchRequest& m) {
  j = {{"stream", to_string(m.stream)}, {"first", m.first}, {"count", m.count}};
}

void from_json(const json& j, FetchRequest& m) {
  m.stream = stream_from_string(string_arg(j, "stream"), "stream");
  m.first = uint_arg(j, "first");
  m.count = uint_arg(j, "count");
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
  put_if(j, "V0", m.V0);
  put_if(j, "f", m.f);
  put_if(j, "C_dr", m.C_dr);
  put_if(j, "e_dr", m.e_dr);
  put_if(j, "lease_s", m.lease_s);
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
  m.V0 = optional_number_arg(j, "V0");
  m.f = optional_number_arg(j, "f");
  m.C_dr = optional_number_arg(j, "C_dr");
  m.e_dr = optional_number_arg(j, "e_dr");
  m.lease_s = optional_number_arg(j, "lease_s");
}

void to_json(json& j, const OutputEnd& m) {
  j = {{"state", firmware::to_string(m.state)}, {"zero_confirmed", m.zero_confirmed},
       {"zero_read_back", m.zero_read_back},    {"acknowledged_V", nil_or(m.acknowledged_V)},
       {"zero_writes", m.zero_writes},          {"zero_status", m.zero_status},
       {"enabled_ever", m.enabled_ever},        {"enable_status", m.enable_status}};
}

void from_json(const json& j, OutputEnd& m) {
  m.state = named_field(j, "state", firmware::kOutputStateNames);
  m.zero_confirmed = field<bool>(j, "zero_confirmed");
  m.zero_read_back = optional_field<bool>(j, "zero_read_back").value_or(false);
  m.acknowledged_V = optional_field<double>(j, "acknowledged_V");
  m.zero_writes = field<std::uint32_t>(j, "zero_writes");
  m.zero_status = optional_field<std::string>(j, "zero_status").value_or("ok");
  m.enabled_ever = optional_field<bool>(j, "enabled_ever").value_or(true);
  m.enable_status = field<std::string>(j, "enable_status");
}

void to_json(json& j, const RunSummary& m) {
  j = {{"cause", firmware::to_string(m.cause)},
       {"output", m.output},
       {"drive", m.drive},
       {"sensor", m.sensor},
       {"realtime", m.realtime},
       {"samples", {{"drive", m.drive_samples}, {"sensor", m.sensor_samples}}}};
  if (!m.move.is_null()) j["move"] = m.move;
  if (m.has_calibration) j["calibration"] = m.calibration;
  if (m.calibration_error) j["calibration_error"] = *m.calibration_error;
}

void from_json(const json& j, RunSummary& m) {
  m.cause = named_field(j, "cause", firmware::kStopCauseNames);
  m.output = field<OutputEnd>(j, "output");
  m.drive = field<LoopHealth>(j, "drive");
  m.sensor = field<LoopHealth>(j, "sensor");
  m.realtime =
      optional_field<std::vector<std::string>>(j, "realtime").value_or(std::vector<std::string>{});
  const json samples = object_field(j, "samples");
  m.drive_samples = field<std::uint64_t>(samples, "drive");
  m.sensor_samples = field<std::uint64_t>(samples, "sensor");
  m.move = j.value("move", json());
  m.has_calibration = j.contains("calibration");
  m.calibration = j.value("calibration", json());
  m.calibration_error = optional_field<std::string>(j, "calibration_error");
}

void to_json(json& j, const StateEvent& m) {
  j = {{"state", to_string(m.state)},
       {"board_ns", m.board_ns},
       {"run", nil_or(m.run)},
       {"fault", nil_or(m.fault)}};
  if (m.summary) j["summary"] = *m.summary;
}

void from_json(const json& j, StateEvent& m) {
  m.state = named_field(j, "state", kBoardStateNames);
  m.board_ns = field<std::int64_t>(j, "board_ns");
  m.run = optional_field<std::uint64_t>(j, "run");
  m.fault = optional_named_field(j, "fault", firmware::kStopCauseNames);
  m.summary = optional_field<RunSummary>(j, "summary");
}

void to_json(json& j, const HealthEvent& m) {
  j = {{"state", to_string(m.state)}, {"board_ns", m.board_ns}};
  if (m.drive) j["drive"] = *m.drive;
  if (m.sensor) j["sensor"] = *m.sensor;
  if (!m.move.is_null()) j["move"] = m.move;
  if (m.calibration_progress) j["calibration_progress"] = *m.calibration_progress;
}

void from_json(const json& j, HealthEvent& m) {
  m.state = named_field(j, "state", kBoardStateNames);
  m.board_ns = field<std::int64_t>(j, "board_ns");
  m.drive = optional_field<LoopHealth>(j, "drive");
  m.sensor = optional_field<LoopHealth>(j, "sensor");
  m.move = j.value("move", json());
  m.calibration_progress = optional_field<double>(j, "calibration_progress");
}

void to_json(json& j, const RunStatus& m) {
  j = {{"id", m.id},           {"t0_ns", m.t0_ns},       {"duration_s", m.duration_s},
       {"lease_s", m.lease_s}, {"finished", m.finished}, {"drive", m.drive},
       {"sensor", m.sensor}};
  if (m.summary) j["summary"] = *m.summary;
  if (!m.move.is_null()) j["move"] = m.move;
  if (m.calibration_progress) j["calibration_progress"] = *m.calibration_progress;
}

void from_json(const json& j, RunStatus& m) {
  m.id = field<std::uint64_t>(j, "id");
  m.t0_ns = field<std::int64_t>(j, "t0_ns");
  m.duration_s = field<double>(j, "duration_s");
  m.lease_s = field<double>(j, "lease_s");
  m.finished = field<bool>(j, "finished");
  m.drive = field<LoopHealth>(j, "drive");
  m.sensor = field<LoopHealth>(j, "sensor");
  m.summary = optional_field<RunSummary>(j, "summary");
  m.move = j.value("move", json());
  m.calibration_progress = optional_field<double>(j, "calibration_progress");
}

void to_json(json& j, const Status& m) {
  const auto span = [](const Status::Span& s) {
    return json{{"first", s.first}, {"next", s.next}};
  };
  j = {{"state", to_string(m.state)},
       {"board_ns", m.board_ns},
       {"controller", m.controller},
       {"controlled", m.controlled},
       {"fault", nil_or(m.fault)},
       {"recorder", {{"drive", span(m.drive_recorded)}, {"sensor", span(m.sensor_recorded)}}},
       {"position",
        {{"position_rad", nil_or(m.position_rad)},
         {"zero_displacement_m", nil_or(m.zero_displacement_m)}}},
       {"calibration", m.calibration}};
  if (m.configured) j["configured"] = *m.configured;
  if (m.run) j["run"] = *m.run;
  j["requests"] = m.requests;
}

void from_json(const json& j, Status& m) {
  const auto span = [](const json& s) {
    return Status::Span{field<std::uint64_t>(s, "first"), field<std::uint64_t>(s, "next")};
  };
  m.state = named_field(j, "state", kBoardStateNames);
  m.board_ns = field<std::int64_t>(j, "board_ns");
  m.controller = field<bool>(j, "controller");
  m.controlled = field<bool>(j, "controlled");
  m.fault = optional_named_field(j, "fault", firmware::kStopCauseNames);
  const json recorder = object_field(j, "recorder");
  m.drive_recorded = span(object_field(recorder, "drive"));
  m.sensor_recorded = span(object_field(recorder, "sensor"));
  const json position = object_field(j, "position");
  m.position_rad = optional_field<double>(position, "position_rad");
  m.zero_displacement_m = optional_field<double>(position, "zero_displacement_m");
  m.calibration = j.value("calibration", json());
  m.configured.reset();
  if (j.contains("configured") && !j.at("configured").is_null()) {
    m.configured = field<ConfigureRequest>(j, "configured");
  }
  m.run = optional_field<RunStatus>(j, "run");
  m.requests = optional_field<std::map<std::string, std::uint64_t>>(j, "requests").value_or(
      std::map<std::string, std::uint64_t>{});
}

template <class T>
T decode(const json& j) {
  if (!j.is_object()) throw ProtocolError(code::malformed, "", "not a map");
  return j.get<T>();
}

void to_json(json& j, BoardState s) {
  j = to_string(s);
}

template Hello decode<Hello>(const json&);
template LoopHealth decode<LoopHealth>(const json&);
template ClockReply decode<ClockReply>(const json&);
template ConfigureRequest decode<ConfigureRequest>(const json&);
template StartRequest decode<StartRequest>(const json&);
template StepRequest decode<StepRequest>(const json&);
template MoveToRequest decode<MoveToRequest>(const json&);
template CalibrateRequest decode<CalibrateRequest>(const json&);
template LeaseRequest decode<LeaseRequest>(const json&);
template FetchRequest decode<FetchRequest>(const json&);
template RunSummary decode<RunSummary>(const json&);
template StateEvent decode<StateEvent>(const json&);
template HealthEvent decode<HealthEvent>(const json&);
template RunStatus decode<RunStatus>(const json&);
template Status decode<Status>(const json&);

}  // namespace piezo::protocol

namespace piezo::firmware {
void to_json(nlohmann::json& j, StopCause c) {
  j = to_string(c);
}
void to_json(nlohmann::json& j, OutputState s) {
  j = to_string(s);
}
}  // namespace piezo::firmware
