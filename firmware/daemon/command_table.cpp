#include "command_table.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/board_identity.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::daemon {

CommandTable::CommandTable(std::vector<Command> commands, std::string board_id)
    : commands_(std::move(commands)), board_id_(std::move(board_id)) {
  for (Command& c : commands_) {
    if (!protocol::names_board(c.name)) continue;
    protocol::ArgumentSpec board;
    board.name = wire_key::board;
    board.type = firmware::ArgumentType::text;
    board.default_text = "none: not checked";
    board.doc =
        "the board start this request is for (`hello.board_id`); another one's is refused "
        "(`stale_board`) and does nothing";
    c.args.push_back(std::move(board));
  }
}

nlohmann::json CommandTable::dispatch(const std::string& client, const std::string& cmd,
                                      const nlohmann::json& args, const RunState& state) const {
  const auto it = std::find_if(commands_.begin(), commands_.end(),
                               [&](const Command& c) { return c.name == cmd; });
  ++counts_[static_cast<std::size_t>(it - commands_.begin())];
  if (it == commands_.end()) {
    throw protocol::ProtocolError(
        protocol::code::unknown_command, "cmd",
        fmt::format("cmd: \"{}\" is not a command (allowed: {})", cmd, names()));
  }
  std::vector<std::string_view> takes;
  for (const auto& a : it->args) takes.emplace_back(a.name);
  protocol::refuse_unknown_args(args, takes, it->name);
  // Before who may send it: a request for a board start that is gone is
  // nobody's now, whatever it asks.
  if (const auto board = args.find(wire_key::board);
      board != args.end() && protocol::names_board(it->name) &&
      !(board->is_string() && board->get<std::string>() == board_id_)) {
    if (!board->is_string()) {
      throw protocol::ProtocolError(
          protocol::code::bad_argument, wire_key::board,
          fmt::format("{}: board: expected text (hello's board_id)", cmd));
    }
    throw protocol::ProtocolError(
        protocol::code::stale_board, wire_key::board,
        fmt::format("{}: board: \"{}\" is an earlier start of this board (now \"{}\"): it "
                    "restarted since the request was made; ask hello again",
                    cmd, board->get<std::string>(), board_id_));
  }
  if (it->caller == Caller::controller) {
    const std::string name(it->name);
    state.require_controller(client, name.c_str());
  }
  return it->handler(client, args);
}

std::string CommandTable::names() const {
  std::string out;
  for (const auto& c : commands_) {
    if (!out.empty()) out += ", ";
    out += c.name;
  }
  return out;
}

std::vector<protocol::CommandSpec> CommandTable::specs() const {
  std::vector<protocol::CommandSpec> out;
  for (const auto& c : commands_) {
    out.push_back({std::string(c.name), c.caller == Caller::anyone, c.args});
  }
  return out;
}

std::map<std::string, std::uint64_t> CommandTable::counts() const {
  std::map<std::string, std::uint64_t> out;
  for (std::size_t i = 0; i < commands_.size(); ++i)
    out[std::string(commands_[i].name)] = counts_[i];
  out[protocol::kUnknownCommands] = counts_.back();
  return out;
}

}  // namespace piezo::daemon
