#include "piezo/protocol/message.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "piezo/firmware/wire_keys.hpp"

namespace piezo::protocol {
namespace {

using nlohmann::json;

// No message nests deeper than this; the parser recurses once per level,
// so a few kilobytes of nested arrays would otherwise overflow the stack
// (found by tests/fuzz).
constexpr std::size_t kMaxDepth = 32;

/// nlohmann's DOM builder, refusing to go deeper than kMaxDepth. It notes
/// the top-level map's "id" as it passes, so that a map that fails later
/// (an integer key, a truncated value) is still refused under its id.
class BoundedDomParser : public nlohmann::detail::json_sax_dom_parser<json> {
 public:
  explicit BoundedDomParser(json& result) : json_sax_dom_parser(result, false) {}
  bool key(std::string& k) {
    id_next_ = depth_ == 1 && k == wire_key::id;
    return json_sax_dom_parser::key(k);
  }
  bool number_unsigned(json::number_unsigned_t v) {
    if (id_next_ && depth_ == 1) id_ = v;
    id_next_ = false;
    return json_sax_dom_parser::number_unsigned(v);
  }
  [[nodiscard]] std::optional<std::uint64_t> id() const { return id_; }
  bool start_object(std::size_t n) { return deeper() && json_sax_dom_parser::start_object(n); }
  bool start_array(std::size_t n) { return deeper() && json_sax_dom_parser::start_array(n); }
  bool end_object() {
    --depth_;
    return json_sax_dom_parser::end_object();
  }
  bool end_array() {
    --depth_;
    return json_sax_dom_parser::end_array();
  }
  [[nodiscard]] bool too_deep() const { return too_deep_; }

 private:
  bool deeper() {
    too_deep_ = ++depth_ > kMaxDepth;
    return !too_deep_;
  }
  std::size_t depth_ = 0;
  bool too_deep_ = false;
  bool id_next_ = false;
  std::optional<std::uint64_t> id_;
};

/// A MessagePack map; `id_seen`, when given, receives the top-level "id"
/// read before any fault.
json parse_msgpack(std::string_view bytes, bool limited = true,
                   std::optional<std::uint64_t>* id_seen = nullptr) {
  if (limited && bytes.size() > kMaxMessageBytes) {
    throw ProtocolError(
        code::too_large, "",
        fmt::format("message of {} bytes; at most {} are read", bytes.size(), kMaxMessageBytes));
  }
  json j;
  BoundedDomParser sax(j);
  const bool parsed =
      json::sax_parse(bytes.begin(), bytes.end(), &sax, json::input_format_t::msgpack, true);
  if (id_seen != nullptr) *id_seen = sax.id();
  if (sax.too_deep()) {
    throw ProtocolError(code::malformed, "",
                        fmt::format("nested deeper than {} levels", kMaxDepth));
  }
  if (!parsed || sax.is_errored()) {
    throw ProtocolError(code::malformed, "", "not a MessagePack value (or truncated)");
  }
  if (!j.is_object()) throw ProtocolError(code::malformed, "", "not a MessagePack map");
  return j;
}

std::string to_bytes(const json& j) {
  const std::vector<std::uint8_t> bytes = json::to_msgpack(j);
  return {bytes.begin(), bytes.end()};
}

const json* find(const json& args, std::string_view key) {
  const auto it = args.find(key);
  return it == args.end() || it->is_null() ? nullptr : &*it;
}

ProtocolError wrong_type(std::string_view key, const char* wanted, const json& got) {
  return {code::bad_argument, key,
          fmt::format("{}: must be {}, got {}", key, wanted, got.type_name())};
}

ProtocolError missing(std::string_view key) {
  return {code::bad_argument, key, fmt::format("{}: missing", key)};
}

}  // namespace

std::string encode_request(const Request& r) {
  return to_bytes(json{{wire_key::id, r.id}, {"cmd", r.cmd}, {"args", r.args}});
}

Request decode_request(std::string_view bytes, std::optional<std::uint64_t>& id_out) {
  if (bytes.size() > kMaxMessageBytes) {
    // Refused, but with its id where the map reads, so that the client can
    // match the refusal to its request.
    try {
      const json big = parse_msgpack(bytes, false);
      if (const json* id = find(big, wire_key::id); id != nullptr && id->is_number_unsigned()) {
        id_out = id->get<std::uint64_t>();
      }
    } catch (const ProtocolError&) {
      // Not even a map: the refusal goes without an id.
    }
  }
  const json j = parse_msgpack(bytes, true, &id_out);
  Request r;
  // Without an id or a cmd it is no request at all: malformed, as the
  // document says, not a command with a bad argument.
  const json* id = find(j, wire_key::id);
  if (id == nullptr) throw ProtocolError(code::malformed, wire_key::id, "id: missing");
  if (!id->is_number_unsigned()) throw wrong_type(wire_key::id, "an unsigned integer", *id);
  r.id = id->get<std::uint64_t>();
  id_out = r.id;
  const json* cmd = find(j, "cmd");
  if (cmd == nullptr) throw ProtocolError(code::malformed, "cmd", "cmd: missing");
  if (!cmd->is_string()) throw wrong_type("cmd", "a string", *cmd);
  r.cmd = cmd->get<std::string>();
  if (const json* args = find(j, "args"); args != nullptr) {
    if (!args->is_object()) throw wrong_type("args", "a map", *args);
    r.args = *args;
  }
  return r;
}

std::string encode_reply(std::uint64_t id, const json& result) {
  return to_bytes(json{{wire_key::id, id}, {"ok", true}, {"result", result}});
}

std::string encode_error(std::optional<std::uint64_t> id, const ErrorBody& e) {
  json j{{"ok", false}, {"error", {{"code", e.code}, {"key", e.key}, {"message", e.message}}}};
  j[wire_key::id] = id ? json(*id) : json(nullptr);
  return to_bytes(j);
}

Reply decode_reply(std::string_view bytes) {
  // Replies are not limited: a fetch carries up to 100000 samples.
  const json j = parse_msgpack(bytes, false);
  Reply r;
  if (const json* id = find(j, wire_key::id); id != nullptr && id->is_number_unsigned()) {
    r.id = id->get<std::uint64_t>();
  }
  const json* ok = find(j, "ok");
  if (ok == nullptr || !ok->is_boolean())
    throw ProtocolError(code::malformed, "ok", "reply without \"ok\"");
  r.ok = ok->get<bool>();
  if (r.ok) {
    if (const json* result = find(j, "result"); result != nullptr) r.result = *result;
  } else {
    const json* e = find(j, "error");
    if (e == nullptr || !e->is_object()) {
      throw ProtocolError(code::malformed, "error", "error reply without \"error\"");
    }
    // Found by fuzzing: a non-string field threw nlohmann's type_error.
    const auto text = [e](const char* key) {
      const json* v = find(*e, key);
      return v != nullptr && v->is_string() ? v->get<std::string>() : std::string();
    };
    r.error = {text("code"), text("key"), text("message")};
  }
  return r;
}

std::string encode_map(const json& map) {
  return to_bytes(map);
}
json decode_map(std::string_view bytes) {
  return parse_msgpack(bytes, false);
}

double number_arg(const json& args, std::string_view key, std::optional<double> fallback) {
  const json* v = find(args, key);
  if (v == nullptr) {
    if (fallback) return *fallback;
    throw missing(key);
  }
  if (!v->is_number()) throw wrong_type(key, "a number", *v);
  return v->get<double>();
}

std::uint64_t uint_arg(const json& args, std::string_view key,
                       std::optional<std::uint64_t> fallback) {
  const json* v = find(args, key);
  if (v == nullptr) {
    if (fallback) return *fallback;
    throw missing(key);
  }
  // Numbers are floats or integers: 10.0 is the integer 10.
  if (v->is_number_float()) {
    const double d = v->get<double>();
    if (d >= 0.0 && d < 0x1p64 && d == std::floor(d)) return static_cast<std::uint64_t>(d);
  }
  if (!v->is_number_unsigned()) throw wrong_type(key, "an unsigned integer", *v);
  return v->get<std::uint64_t>();
}

void refuse_unknown_args(const json& args, const std::vector<std::string_view>& known,
                         std::string_view cmd) {
  for (const auto& [key, value] : args.items()) {
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string allowed;
    for (std::string_view k : known) allowed += (allowed.empty() ? "" : ", ") + std::string(k);
    throw ProtocolError(code::bad_argument, key,
                        fmt::format("{}: not an argument of {} (allowed: {})", key, cmd,
                                    allowed.empty() ? "none" : allowed));
  }
}

std::string string_arg(const json& args, std::string_view key,
                       std::optional<std::string> fallback) {
  const json* v = find(args, key);
  if (v == nullptr) {
    if (fallback) return *fallback;
    throw missing(key);
  }
  if (!v->is_string()) throw wrong_type(key, "a string", *v);
  return v->get<std::string>();
}

bool bool_arg(const json& args, std::string_view key, std::optional<bool> fallback) {
  const json* v = find(args, key);
  if (v == nullptr) {
    if (fallback) return *fallback;
    throw missing(key);
  }
  if (!v->is_boolean()) throw wrong_type(key, "true or false", *v);
  return v->get<bool>();
}

}  // namespace piezo::protocol
