// `piezo move`: a closed-loop move to an angle from the board's zero,
// logged as a run. Its options are the declared fields of a move's request
// (firmware::kMoveFields), one each.

#include <fmt/format.h>

#include <cctype>
#include <variant>

#include "exit_codes.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/move_request.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/overload.hpp"
#include "run_command.hpp"

namespace piezo::host {
namespace {

/// The request as `piezo move` was given it: each field's option, and
/// which of them the user gave (the others come from the config's [move]).
struct MoveOptions {
  firmware::MoveRequest request;
  std::vector<std::pair<const firmware::MoveField*, const CLI::Option*>> given;
};

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
config::RunSettings::Move move_request(const MoveOptions& m, const RunOptions& o,
                                       const firmware::MoveRequest& defaults) {
  config::RunSettings::Move move;
  static_cast<firmware::MoveRequest&>(move) = defaults;
  for (const auto& [field, option] : m.given) {
    if (option->count() == 0) continue;
    std::visit([&](auto member) { move.*member = m.request.*member; }, field->member);
  }
  if (const auto breach = firmware::check_move(move)) {
    const firmware::MoveField* field = firmware::find_move_field(breach->key);
    throw config::ConfigError(field ? std::string(field->option) : "piezo move", breach->key,
                              breach->message);
  }
  move.V0 = o.V0;
  move.f = o.f;
  return move;
}

/// `piezo move`'s result: the board's account of the move, the time it took
/// and the run it was, in one object.
nlohmann::json move_result(const RunSummary& s, const nlohmann::json& run) {
  nlohmann::json m = s.board.move ? nlohmann::json(*s.board.move) : nlohmann::json::object();
  if (!m.contains("stop_cause")) m["stop_cause"] = s.stop_cause();
  if (!m.contains("on_target")) m["on_target"] = false;
  for (const char* key : {"position_rad", "error_rad", "steps"}) {
    if (!m.contains(key)) m[key] = nullptr;
  }
  const bool on_target = m.at("on_target").get<bool>();
  m["time_s"] = on_target ? m.at("on_target_at_s") : nlohmann::json(s.t_end_s);
  m["run_dir"] = run.at("run_dir");
  m["log"] = run.at("log");
  m["run"] = run;
  return m;
}

std::string move_text(const nlohmann::json& m) {
  const auto mrad = [](const nlohmann::json& v) {
    return v.is_number() ? fmt::format("{:.4f} mrad", 1e3 * v.get<double>()) : std::string("-");
  };
  const auto urad = [](const nlohmann::json& v) {
    return v.is_number() ? fmt::format("{:.1f} urad", 1e6 * v.get<double>()) : std::string("-");
  };
  return fmt::format("move {} ({}): position {} for target {}, error {}, {} steps, {:.3f} s\n",
                     m.at("on_target").get<bool>() ? "on target" : "NOT on target",
                     m.at("stop_cause").get<std::string>(),
                     mrad(m.value("position_rad", nlohmann::json())),
                     mrad(m.value("target_rad", nlohmann::json())), urad(m.at("error_rad")),
                     m.at("steps").is_number() ? m.at("steps").get<long>() : 0L,
                     m.at("time_s").is_number() ? m.at("time_s").get<double>() : 0.0);
}

}  // namespace

void add_move_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RunOptions>();
  auto m = std::make_shared<MoveOptions>();
  CLI::App* cmd = app.add_subcommand(
      "move", "Closed-loop move to an angle from the board's zero (logged as a run)");
  add_move_options(*cmd, *m);
  add_run_options(*cmd, *o, "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)",
                  "piezod's address (default: [rig] address, or in-process)",
                  "Print one JSON object: position_rad, error_rad, on_target, time_s, steps, "
                  "stop_cause, ... and the run");
  cmd->add_option("--V0", o->V0, "Coarse steps' peak voltage [V] (default: [drive] V0)");
  cmd->add_option("--f", o->f,
                  "Coarse steps' frequency [Hz] (default: the board's calibrated fastest, else "
                  "its [drive] f)");
  RunProgram program{[m, o](config::ConfigFile& config) {
                       config.host.run.move = move_request(*m, *o, config.host.run.move_defaults);
                       config.host.run.duration_s = config.host.run.move->timeout_s;
                     },
                     [](const FinishedRun& run) {
                       const nlohmann::json move = move_result(run.summary, run.result);
                       write_out(stdout, run.options.json
                                             ? move.dump() + "\n"
                                             : move_text(move) + summary_text(run.summary, run.log,
                                                                              run.signal, nullptr));
                       if (run.summary.output_state() != "confirmed") {
                         write_out(stderr, "piezo: " + output_line(run.summary) + "\n");
                       }
                       if (exit_code(run.summary) != 0) return exit_code(run.summary);
                       return move.at("on_target").get<bool>() ? 0 : kExitFailed;
                     }};
  commands.add(cmd, run_command(cmd, o, std::move(program)));
}

}  // namespace piezo::host
