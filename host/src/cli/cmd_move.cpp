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
#include "piezo/protocol/wire_fields.hpp"
#include "run_command.hpp"

namespace piezo::host {
namespace {
/// `piezo move`'s result: the board's account of the move, the time it took
/// and the run it was, in one object.
struct MoveResult {
  protocol::MoveAccount move;  ///< the board's (a move that never began: its run's end)
  double time_s = 0.0;         ///< to on target, else the whole run
  std::string run_dir, log;
  nlohmann::json run;  ///< the run's own JSON summary
};

}  // namespace
}  // namespace piezo::host

template <>
struct piezo::protocol::wire::Fields<piezo::host::MoveResult> {
  using T = piezo::host::MoveResult;
  static constexpr auto list =
      std::tuple{inline_fields(&T::move), field("time_s", &T::time_s),
                 field("run_dir", &T::run_dir), field("log", &T::log), field("run", &T::run)};
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
asked::Move move_request(const MoveOptions& m, const RunOptions& o,
                         const firmware::MoveRequest& defaults) {
  asked::Move move;
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

MoveResult move_result(const FinishedRun& run) {
  const RunSummary& s = run.summary;
  MoveResult r;
  r.move = s.board.move.value_or(protocol::MoveAccount{});
  if (!r.move.stop_cause) r.move.stop_cause = firmware::move_end(r.move.on_target, s.board.cause);
  r.time_s = r.move.on_target ? r.move.on_target_at_s.value_or(s.t_end_s) : s.t_end_s;
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
  const auto& m = r.move;
  return fmt::format("move {} ({}): position {} for target {}, error {}, {} steps, {:.3f} s\n",
                     m.on_target ? "on target" : "NOT on target",
                     firmware::kMoveEndNames.name(*m.stop_cause), mrad(m.position_rad),
                     mrad(m.target_rad), urad(m.error_rad), m.steps, r.time_s);
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
                       return move.move.on_target ? 0 : kExitFailed;
                     }};
  commands.add(cmd, run_command(cmd, o, std::move(program)));
}

}  // namespace piezo::host
