#pragma once
/// @file
/// The board's data dictionary (docs/protocol.md, `describe`): every
/// command with its arguments as declared (request_arguments.hpp,
/// move_request.hpp), each range narrowed to the limits of the board that
/// answers, and the names of everything the wire carries as text. Clients
/// take their keywords, defaults and local checks from it instead of
/// copying them; `check_arguments` is the one check they all apply, the
/// same the board applies on arrival.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/firmware/move_request.hpp"
#include "piezo/firmware/request_arguments.hpp"
#include "piezo/protocol/messages.hpp"

namespace piezo::protocol {

/// One argument as `describe` gives it.
struct ArgumentSpec {
  std::string name;
  firmware::ArgumentType type = firmware::ArgumentType::number;
  std::string unit;
  Interval allowed;                  ///< a number's or an integer's
  std::string limit;                 ///< the board's limit that is `allowed.max` ("": none)
  std::vector<std::string> choices;  ///< a choice's names
  bool required = false;
  nlohmann::json default_value;  ///< a literal default; nil: required, or the board decides
  std::string default_text;      ///< the default as the docs say it
  std::string doc;
};

[[nodiscard]] ArgumentSpec spec_of(const firmware::Argument& a);
[[nodiscard]] ArgumentSpec spec_of(const firmware::MoveField& f);

/// The arguments a request type takes (arguments_of: its `kArgs`, or its fields').
template <class Request>
[[nodiscard]] std::vector<ArgumentSpec> specs_of() {
  std::vector<ArgumentSpec> out;
  for (const firmware::Argument& a : arguments_of<Request>()) out.push_back(spec_of(a));
  return out;
}
/// `move_to`'s: every field of the move's request, then the waveform's.
[[nodiscard]] std::vector<ArgumentSpec> move_to_specs();

/// The value of the board's limit `name` (`hello.limits`); nullopt: no such limit.
[[nodiscard]] std::optional<double> limit_value(const Hello::Limits& limits, std::string_view name);

/// A command of the dictionary: who may send it and what it takes.
struct CommandSpec {
  std::string name;
  bool anyone = false;  ///< any client (watch, fetch, e-stop); else the controller
  std::vector<ArgumentSpec> args;
};

/// `describe`'s reply: {protocol, commands: {NAME: {caller, args: [...]}},
/// names: {states, stop_causes, move_ends, move_states, error_codes, ...}};
/// each argument's upper end is the value of its limit on this board.
[[nodiscard]] nlohmann::json describe(const std::vector<CommandSpec>& commands,
                                      const Hello::Limits& limits);

/// Where a request breaks its command's described arguments.
struct ArgumentBreach {
  std::string code;  ///< bad_argument (unknown, wrong type) or out_of_limits
  std::string key;
  std::string message;
};

/// Checks `args` against one command of a `describe` reply: names it does
/// not take, types, choices and ranges (naming the board's limit where one
/// bounds the value). nullopt: the board would take them.
[[nodiscard]] std::optional<ArgumentBreach> check_arguments(const nlohmann::json& dictionary,
                                                            std::string_view command,
                                                            const nlohmann::json& args);

}  // namespace piezo::protocol
