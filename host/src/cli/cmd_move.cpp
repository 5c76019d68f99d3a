// `piezo move`: a closed-loop move to an angle from the board's zero,
// logged as a run. Its options are the declared fields of a move's request
// (firmware::kMoveFields), one each; its target, `--to`, takes AXIS=RAD
// once per axis for a group move of several axes.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <variant>

#include "exit_codes.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/move_request.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/overload.hpp"
#include "piezo/protocol/wire_fields.hpp"
#include "run_command.hpp"

namespace piezo::host {
namespace {
/// `piezo move`'s result: the board's account of the move, the time it took
/// and the run it was, in one object.
struct MoveResult {
  bool on_target = false;  ///< every axis
  std::string stop_cause;  ///< the run's: the first axis that did not arrive says how it ended
  double time_s = 0.0;     ///< to on target (its last axis), else the whole run
  std::string run_dir, log;
  nlohmann::json run;  ///< the run's own JSON summary
  /// Every axis's account, in the log's order, one or several (a move that
  /// never began: its run's end).
  std::vector<protocol::MoveAccount> moves;
};

}  // namespace
}  // namespace piezo::host

template <>
struct piezo::protocol::wire::Fields<piezo::host::MoveResult> {
  using T = piezo::host::MoveResult;
  static constexpr auto list = std::tuple{field("on_target", &T::on_target),
                                          field("stop_cause", &T::stop_cause),
                                          field("time_s", &T::time_s),
                                          field("run_dir", &T::run_dir),
                                          field("log", &T::log),
                                          field("run", &T::run),
                                          field(piezo::wire_key::moves, &T::moves)};
};

namespace piezo::host {
namespace {

void to_json(nlohmann::json& j, const MoveResult& m) {
  j = protocol::wire::encode(m);
}

/// The request as `piezo move` was given it: each field's option, and
/// which of them the user gave (the others come from the config's [move]).
struct MoveOptions {
  firmware::MoveRequest request;
  std::vector<std::pair<const firmware::MoveField*, const CLI::Option*>> given;
  std::vector<std::string> to;  ///< --to as given: RAD, or AXIS=RAD for each axis of a group
};

bool is_target(const firmware::MoveField& field) {
  return field.name == wire_key::target_rad;
}

std::vector<std::string> approach_names() {
  std::vector<std::string> out;
  for (const auto& [value, name] : firmware::kApproachNames.entries()) out.emplace_back(name);
  return out;
}

/// One option per declared field of a move's request (kMoveFields).
void add_move_options(CLI::App& cmd, MoveOptions& o) {
  for (const firmware::MoveField& field : firmware::kMoveFields) {
    const std::string option(field.option);
    const std::string unit = field.unit.empty() ? "" : " [" + std::string(field.unit) + "]";
    std::string doc = std::string(field.doc) + unit;
    doc[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(doc[0])));
    if (!field.required) {
      doc += " (default: [move] " + std::string(field.name) + ", else " +
             firmware::default_text(field) + ")";
    }
    if (is_target(field)) {
      // RAD on one axis, or AXIS=RAD once per axis of a group move.
      cmd.add_option("--to", o.to,
                     doc + "; AXIS=RAD (repeated) moves several axes in one group move")
          ->required();
      continue;
    }
    CLI::Option* added =
        std::visit(Overload{
                       [&](double firmware::MoveRequest::*m) {
                         return cmd.add_option(option, o.request.*m, doc);
                       },
                       [&](std::uint64_t firmware::MoveRequest::*m) {
                         return cmd.add_option(option, o.request.*m, doc)
                             ->check(CLI::Range(static_cast<std::uint64_t>(field.allowed.min),
                                                static_cast<std::uint64_t>(field.allowed.max)));
                       },
                       [&](bool firmware::MoveRequest::*m) {
                         // The flag says the opposite of the default ("--no-protect").
                         const bool flagged = !(firmware::MoveRequest{}.*m);
                         return cmd.add_flag_callback(
                             option, [&o, m, flagged] { o.request.*m = flagged; }, doc);
                       },
                       [&](firmware::Approach firmware::MoveRequest::*m) {
                         return cmd
                             .add_option_function<std::string>(
                                 option,
                                 [&o, m](const std::string& text) {
                                   o.request.*m = *firmware::kApproachNames.parse(text);
                                 },
                                 doc)
                             ->check(CLI::IsMember(approach_names()));
                       },
                   },
                   field.member);
    if (field.required) added->required();
    o.given.emplace_back(&field, added);
  }
}

/// `piezo move`'s request: each field from its option when the user gave
/// it, else from the config's [move]. The board refuses the same (one
/// rule); checked here first so that a refused move leaves no run
/// directory behind.
/// A number that is all of `text`, else nullopt.
std::optional<double> whole_number(const std::string& text) {
  std::size_t used = 0;
  try {
    const double value = std::stod(text, &used);
    if (used == text.size()) return value;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

/// --to's targets into `move`: one RAD (target_rad), or AXIS=RAD each.
void read_targets(const std::vector<std::string>& to, const RunOptions& o, asked::Move& move) {
  if (to.size() == 1 && to.front().find('=') == std::string::npos) {
    const auto value = whole_number(to.front());
    if (!value) throw config::ConfigError("--to", to.front(), "not a number of radians");
    move.target_rad = *value;
    return;
  }
  for (const std::string& text : to) {
    const std::size_t eq = text.find('=');
    const auto value = eq == std::string::npos ? std::nullopt : whole_number(text.substr(eq + 1));
    if (!value || eq == 0) {
      throw config::ConfigError("--to", text,
                                "a group move gives AXIS=RAD for each axis, e.g. --to theta=0.01 "
                                "--to phi=-0.02");
    }
    if (!move.targets.emplace(text.substr(0, eq), *value).second) {
      throw config::ConfigError("--to", text, "names its axis twice");
    }
  }
  if (!o.axis.empty()) {
    throw config::ConfigError("--axis", o.axis, "a group move names its axes in --to AXIS=RAD");
  }
}

asked::Move move_request(const MoveOptions& m, const RunOptions& o,
                         const firmware::MoveRequest& defaults) {
  asked::Move move;
  static_cast<firmware::MoveRequest&>(move) = defaults;
  for (const auto& [field, option] : m.given) {
    if (option->count() == 0) continue;
    std::visit([&](auto member) { move.*member = m.request.*member; }, field->member);
  }
  read_targets(m.to, o, move);
  // A group's targets are checked each as its axis's move, named as the
  // board names them (`targets.AXIS`).
  const auto checked = [](const firmware::MoveRequest& request, const std::string& target_key) {
    if (const auto breach = firmware::check_move(request)) {
      const firmware::MoveField* field = firmware::find_move_field(breach->key);
      const bool target = field != nullptr && is_target(*field);
      throw config::ConfigError(field ? std::string(field->option) : "piezo move",
                                target ? target_key : breach->key, breach->message);
    }
  };
  checked(move, std::string(wire_key::target_rad));
  for (const auto& [axis, target] : move.targets) {
    firmware::MoveRequest one = move;
    one.target_rad = target;
    checked(one, fmt::format("{}.{}", wire_key::targets, axis));
  }
  move.V0 = o.V0;
  move.f = o.f;
  return move;
}

/// An axis's account, with its end in words when the board gave none (a
/// move that never began: its run's end).
protocol::MoveAccount ended(protocol::MoveAccount move, firmware::StopCause cause) {
  if (!move.stop_cause) move.stop_cause = firmware::move_end(move.on_target, cause);
  return move;
}

MoveResult move_result(const FinishedRun& run) {
  const RunSummary& s = run.summary;
  MoveResult r;
  double last_on_target = 0.0;
  for (const auto& axis : s.board.axes) {
    protocol::MoveAccount none;
    none.axis = axis.name;
    r.moves.push_back(ended(axis.move.value_or(none), axis.cause));
    last_on_target = std::max(last_on_target, r.moves.back().on_target_at_s.value_or(s.t_end_s));
  }
  if (r.moves.empty()) {  // the board fell silent before it said how any axis ended
    protocol::MoveAccount none;
    r.moves.push_back(ended(none, s.board.cause));
  }
  r.on_target = std::all_of(r.moves.begin(), r.moves.end(),
                            [](const protocol::MoveAccount& m) { return m.on_target; });
  r.stop_cause = s.stop_cause();
  r.time_s = r.on_target ? last_on_target : s.t_end_s;
  r.run_dir = run.dir.string();
  r.log = run.log.string();
  r.run = run.result;
  return r;
}

std::string move_text(const MoveResult& r) {
  const auto mrad = [](std::optional<double> v) {
    return v ? fmt::format("{:.4f} mrad", 1e3 * *v) : std::string("-");
  };
  const auto urad = [](std::optional<double> v) {
    return v ? fmt::format("{:.1f} urad", 1e6 * *v) : std::string("-");
  };
  const auto line = [&](const protocol::MoveAccount& m, const std::string& what) {
    return fmt::format("{} ({}): position {} for target {}, error {}, {} steps", what,
                       firmware::kMoveEndNames.name(*m.stop_cause), mrad(m.position_rad),
                       mrad(m.target_rad), urad(m.error_rad), m.steps);
  };
  std::string out =
      fmt::format("move {}, {:.3f} s\n", r.on_target ? "on target" : "NOT on target", r.time_s);
  for (const auto& m : r.moves)
    out += "  " +
           line(m, fmt::format("{:<8}{}", m.axis, m.on_target ? "on target" : "NOT on target")) +
           "\n";
  return out;
}

}  // namespace

void add_move_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RunOptions>();
  auto m = std::make_shared<MoveOptions>();
  CLI::App* cmd = app.add_subcommand(
      "move", "Closed-loop move to an angle from the board's zero (logged as a run)");
  add_move_options(*cmd, *m);
  add_run_options(
      *cmd, *o, "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)",
      "piezod's address (default: [rig] address, or in-process)",
      "Print one JSON object: on_target, stop_cause, time_s, moves (each axis's position_rad, "
      "error_rad, steps, ...) and the run");
  cmd->add_option("--V0", o->V0, "Coarse steps' peak voltage [V] (default: [drive] V0)");
  cmd->add_option("--f", o->f,
                  "Coarse steps' frequency [Hz] (default: the board's calibrated fastest, else "
                  "its [drive] f)");
  RunProgram program{[m, o](config::ConfigFile& config) {
                       asked::Move move = move_request(*m, *o, config.host.run.move_defaults);
                       config.host.run.duration_s = move.timeout_s;
                       return move;
                     },
                     [](const FinishedRun& run) {
                       const MoveResult move = move_result(run);
                       write_out(stdout, run.options.json
                                             ? nlohmann::json(move).dump() + "\n"
                                             : move_text(move) + summary_text(run.summary, run.log,
                                                                              run.signal, nullptr));
                       if (run.summary.output_state() != "confirmed") {
                         write_out(stderr, "piezo: " + output_line(run.summary) + "\n");
                       }
                       if (exit_code(run.summary) != 0) return exit_code(run.summary);
                       return move.on_target ? 0 : kExitFailed;
                     }};
  commands.add(cmd, run_command(cmd, o, std::move(program)));
}

}  // namespace piezo::host
