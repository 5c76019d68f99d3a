#include "command_table.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "piezo/protocol/error.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::daemon {

nlohmann::json CommandTable::dispatch(const std::string& client, const std::string& cmd,
                                      const nlohmann::json& args, const RunState& state) const {
  const auto it = std::find_if(commands_.begin(), commands_.end(),
                               [&](const Command& c) { return c.name == cmd; });
  if (it == commands_.end()) {
    throw protocol::ProtocolError(
        protocol::code::unknown_command, "cmd",
        fmt::format("cmd: \"{}\" is not a command (allowed: {})", cmd, names()));
  }
  protocol::refuse_unknown_args(args, it->args, it->name);
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

}  // namespace piezo::daemon
