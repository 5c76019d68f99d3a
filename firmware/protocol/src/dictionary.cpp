#include "piezo/protocol/dictionary.hpp"

#include <fmt/format.h>

#include <cmath>
#include <type_traits>

#include "piezo/firmware/move_state.hpp"
#include "piezo/firmware/output_state.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/overload.hpp"
#include "piezo/protocol/board_state.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/topics.hpp"
#include "piezo/protocol/wire_fields.hpp"

namespace piezo::protocol {
namespace {

using firmware::ArgumentType;
using nlohmann::json;

constexpr std::string_view type_name(ArgumentType t) {
  switch (t) {
    case ArgumentType::integer:
      return "integer";
    case ArgumentType::choice:
      return "choice";
    case ArgumentType::flag:
      return "flag";
    case ArgumentType::map:
      return "map";
    case ArgumentType::text:
      return "text";
    case ArgumentType::number:
      break;
  }
  return "number";
}

std::vector<std::string> split_names(std::string_view list) {
  std::vector<std::string> out;
  while (!list.empty()) {
    const auto comma = list.find(", ");
    out.emplace_back(list.substr(0, comma));
    list = comma == std::string_view::npos ? std::string_view() : list.substr(comma + 2);
  }
  return out;
}

template <class E, std::size_t N>
json names_of(const NameTable<E, N>& table) {
  json out = json::array();
  for (const auto& [value, name] : table.entries()) out.push_back(name);
  return out;
}

/// An infinite bound travels as nil (MessagePack has no infinity a JSON
/// reader of the dictionary would keep).
json bound(double v) {
  return std::isinf(v) ? json(nullptr) : json(v);
}

double bound_of(const json& v, double infinite) {
  return v.is_number() ? v.get<double>() : infinite;
}

std::string allowed_text(const json& a) {
  const double inf = std::numeric_limits<double>::infinity();
  const Interval i{bound_of(a.at("min"), -inf), bound_of(a.at("max"), inf),
                   a.at("min_open").get<bool>(), a.at("max_open").get<bool>()};
  return i.text();
}

}  // namespace

ArgumentSpec spec_of(const firmware::Argument& a) {
  ArgumentSpec s;
  s.name = a.name;
  s.type = a.type;
  s.unit = a.unit;
  s.allowed = a.allowed;
  s.limit = a.limit;
  s.choices = split_names(a.choices);
  s.required = a.default_text == "required";
  s.default_text = a.default_text;
  s.doc = a.doc;
  // A literal default (a number, or one of the choices) is the client's to
  // show; any other text says where the board takes the value from.
  if (!s.required) {
    const std::string text(a.default_text);
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (!text.empty() && end == text.c_str() + text.size()) {
      s.default_value = v;
    } else if (std::find(s.choices.begin(), s.choices.end(), text) != s.choices.end()) {
      s.default_value = text;
    }
  }
  return s;
}

ArgumentSpec spec_of(const firmware::MoveField& f) {
  static const firmware::MoveRequest defaults;
  ArgumentSpec s;
  s.name = f.name;
  s.unit = f.unit;
  s.allowed = f.allowed;
  s.limit = f.limit;
  s.required = f.required;
  s.default_text = f.required ? "required" : firmware::default_text(f);
  s.doc = f.doc;
  std::visit(Overload{
                 [&](double firmware::MoveRequest::*m) {
                   s.type = ArgumentType::number;
                   if (!f.required) s.default_value = defaults.*m;
                 },
                 [&](std::uint64_t firmware::MoveRequest::*m) {
                   s.type = ArgumentType::integer;
                   s.default_value = defaults.*m;
                 },
                 [&](bool firmware::MoveRequest::*m) {
                   s.type = ArgumentType::flag;
                   s.allowed = {};
                   s.default_value = defaults.*m;
                 },
                 [&](firmware::Approach firmware::MoveRequest::*m) {
                   s.type = ArgumentType::choice;
                   s.allowed = {};
                   for (const auto& [value, name] : firmware::kApproachNames.entries()) {
                     s.choices.emplace_back(name);
                   }
                   s.default_value = std::string(firmware::kApproachNames.name(defaults.*m));
                 },
             },
             f.member);
  return s;
}

std::vector<ArgumentSpec> move_to_specs() {
  std::vector<ArgumentSpec> out;
  for (const firmware::MoveField& f : firmware::kMoveFields) out.push_back(spec_of(f));
  for (const firmware::Argument& a : MoveToRequest::kWaveformArgs) out.push_back(spec_of(a));
  return out;
}

std::optional<double> limit_value(const Hello::Limits& limits, std::string_view name) {
  if (name == wire_key::V_max) return limits.V_max;
  if (name == wire_key::f_max_hz) return limits.f_max_hz;
  if (name == wire_key::duration_max_s) return limits.duration_max_s;
  if (name == wire_key::lease_max_s) return limits.lease_max_s;
  return std::nullopt;
}

json describe(const std::vector<CommandSpec>& commands, const Hello::Limits& limits) {
  json described = json::object();
  for (const CommandSpec& c : commands) {
    json args = json::array();
    for (const ArgumentSpec& a : c.args) {
      Interval allowed = a.allowed;
      if (const auto v = limit_value(limits, a.limit)) allowed.max = *v;
      json arg{{wire_key::name, a.name},
               {"type", type_name(a.type)},
               {"unit", a.unit},
               {"required", a.required},
               {"default", a.default_value},
               {"default_text", a.default_text},
               {"doc", a.doc}};
      if (a.type == ArgumentType::number || a.type == ArgumentType::integer) {
        arg["min"] = bound(allowed.min);
        arg["max"] = bound(allowed.max);
        arg["min_open"] = allowed.min_open;
        arg["max_open"] = allowed.max_open;
        arg["limit"] = a.limit.empty() ? json(nullptr) : json(a.limit);
      }
      if (a.type == ArgumentType::choice) arg["choices"] = a.choices;
      args.push_back(std::move(arg));
    }
    described[c.name] = {{"caller", c.anyone ? "anyone" : wire_key::controller}, {"args", args}};
  }
  json error_codes = json::array();
  for (const char* name : code::kAll) error_codes.push_back(name);
  const auto layout = [](const auto& fields) {
    json out = json::array();
    for (const LayoutField& f : fields) {
      out.push_back({{wire_key::name, f.name}, {"type", f.type}, {"offset", f.offset}});
    }
    return out;
  };
  const auto stream = [&](Stream s, std::size_t record_bytes, const auto& fields) {
    return json{{wire_key::id, static_cast<std::uint16_t>(s)},
                {"record_bytes", record_bytes},
                {"fields", layout(fields)}};
  };
  return {
      {wire_key::protocol, kProtocolVersion},
      {"commands", described},
      {"names",
       {{"states", names_of(kBoardStateNames)},
        {"stop_causes", names_of(firmware::kStopCauseNames)},
        {"move_ends", names_of(firmware::kMoveEndNames)},
        {"move_states", names_of(firmware::kMoveStateNames)},
        {"output_states", names_of(firmware::kOutputStateNames)},
        {"error_codes", error_codes},
        {"directions", names_of(model::kDirectionNames)},
        {"approaches", names_of(firmware::kApproachNames)},
        {"streams", names_of(kStreamNames)},
        {"topics", topic::kAll}}},
      {"messages", message_fields()},
      {"frames",
       {{"magic", kFrameMagic},
        {wire_key::version, kFrameVersion},
        {"header_bytes", kFrameHeaderBytes},
        {"header", layout(kFrameHeaderLayout)},
        {"streams",
         {{to_string(Stream::drive), stream(Stream::drive, kDriveRecordBytes, kDriveRecordLayout)},
          {to_string(Stream::sensor),
           stream(Stream::sensor, kSensorRecordBytes, kSensorRecordLayout)}}}}}};
}

std::optional<ArgumentBreach> check_arguments(const json& dictionary, std::string_view command,
                                              const json& args) {
  const std::string cmd(command);
  const json& commands = dictionary.at("commands");
  if (!commands.contains(cmd)) {
    return ArgumentBreach{code::unknown_command, "cmd",
                          fmt::format("\"{}\" is not a command of this board", cmd)};
  }
  const json& declared = commands.at(cmd).at("args");
  std::string takes;
  for (const json& a : declared) {
    takes += (takes.empty() ? "" : ", ") + a.at(wire_key::name).get<std::string>();
  }
  for (const auto& [key, value] : args.items()) {
    const auto it = std::find_if(declared.begin(), declared.end(),
                                 [&](const json& a) { return a.at(wire_key::name) == key; });
    if (it == declared.end()) {
      return ArgumentBreach{code::bad_argument, key,
                            fmt::format("not an argument of {} (it takes: {})", cmd,
                                        takes.empty() ? std::string("none") : takes)};
    }
    const json& a = *it;
    const std::string type = a.at("type").get<std::string>();
    if (value.is_null()) continue;  // absent: the default
    if (type == "flag") {
      if (!value.is_boolean()) {
        return ArgumentBreach{code::bad_argument, key, "expected true or false"};
      }
      continue;
    }
    if (type == "map") {
      if (!value.is_object()) {
        return ArgumentBreach{code::bad_argument, key, "expected a map or nil"};
      }
      continue;
    }
    if (type == "text") {
      if (!value.is_string()) {
        return ArgumentBreach{code::bad_argument, key,
                              fmt::format("expected text; got {}", wire::shown(value))};
      }
      continue;
    }
    if (type == "choice") {
      const json& choices = a.at("choices");
      if (!value.is_string() || std::find(choices.begin(), choices.end(), value) == choices.end()) {
        std::string allowed;
        for (const json& c : choices) {
          allowed += (allowed.empty() ? "" : ", ") + c.get<std::string>();
        }
        return ArgumentBreach{code::bad_argument, key,
                              fmt::format("{}; allowed: {}", wire::shown(value), allowed)};
      }
      continue;
    }
    if (!value.is_number() || value.is_boolean()) {
      return ArgumentBreach{code::bad_argument, key,
                            fmt::format("expected a number; got {}", wire::shown(value))};
    }
    const double v = value.get<double>();
    if (type == "integer" && (v < 0.0 || v != std::floor(v))) {
      return ArgumentBreach{code::bad_argument, key,
                            fmt::format("expected an unsigned integer; got {:g}", v)};
    }
    const double inf = std::numeric_limits<double>::infinity();
    const Interval allowed{bound_of(a.at("min"), -inf), bound_of(a.at("max"), inf),
                           a.at("min_open").get<bool>(), a.at("max_open").get<bool>()};
    if (!allowed.admits(v)) {
      const json& limit = a.at("limit");
      const std::string unit = a.at("unit").get<std::string>();
      return ArgumentBreach{
          code::out_of_limits, key,
          fmt::format("{:g}{} is beyond the board's limits; allowed: {}{}{}", v,
                      unit.empty() ? "" : " " + unit, allowed_text(a),
                      unit.empty() ? "" : " " + unit,
                      limit.is_string()
                          ? fmt::format(" (the board's {} is {:g}{})", limit.get<std::string>(),
                                        allowed.max, unit.empty() ? "" : " " + unit)
                          : std::string())};
    }
  }
  for (const json& a : declared) {
    if (a.at("required").get<bool>() && !args.contains(a.at(wire_key::name).get<std::string>())) {
      const std::string key = a.at(wire_key::name).get<std::string>();
      return ArgumentBreach{code::bad_argument, key, "missing"};
    }
  }
  return std::nullopt;
}

}  // namespace piezo::protocol
