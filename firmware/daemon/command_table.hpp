#pragma once
// piezod's commands as data (docs/protocol.md, "Commands"): each with the
// arguments it takes, who may send it while a run is under way, and its
// handler. Dispatch refuses an unknown command (the reply lists them all),
// an argument the command does not take, and a caller the command does not
// admit, before the handler runs.

#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/protocol/dictionary.hpp"
#include "run_state.hpp"

namespace piezo::daemon {

/// Who may send a command while a client controls the rig.
enum class Caller {
  anyone,      ///< watching, fetching and e-stopping are everyone's
  controller,  ///< anything that changes the run or the rig
};

struct Command {
  using Handler = std::function<nlohmann::json(const std::string& client, const nlohmann::json&)>;
  std::string_view name;
  Caller caller;
  std::vector<protocol::ArgumentSpec> args;  ///< as declared (request_arguments.hpp)
  Handler handler;
};

class CommandTable {
 public:
  /// `board_id`: this board start's identity; the commands that name the
  /// board (protocol::names_board) take it as their optional `board`.
  CommandTable(std::vector<Command> commands, std::string board_id);
  /// Runs `cmd` for `client`; throws ProtocolError for what it refuses (a
  /// request naming another board start: `stale_board`, before anything else).
  [[nodiscard]] nlohmann::json dispatch(const std::string& client, const std::string& cmd,
                                        const nlohmann::json& args, const RunState& state) const;
  /// The commands' names, comma-separated, in the table's order.
  [[nodiscard]] std::string names() const;
  /// The commands as the board's dictionary lists them.
  [[nodiscard]] std::vector<protocol::CommandSpec> specs() const;
  /// How many requests each command has had (taken or refused), and the
  /// unknown ones under `protocol::kUnknownCommands`.
  [[nodiscard]] std::map<std::string, std::uint64_t> counts() const;

 private:
  std::vector<Command> commands_;
  std::string board_id_;
  mutable std::vector<std::uint64_t> counts_ = std::vector<std::uint64_t>(commands_.size() + 1);
};

}  // namespace piezo::daemon
