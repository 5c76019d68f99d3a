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
  ++counts_[static_cast<std::size_t>(it - commands_.begin())];
  if (it == commands_.end()) {
    throw protocol::ProtocolError(
        protocol::code::unknown_command, "cmd",
        fmt::format("cmd: \"{}\" is not a command (allowed: {})", cmd, names()));
  }
  std::vector<std::string_view> takes;
  for (const auto& a : it->args) takes.emplace_back(a.name);
  protocol::refuse_unknown_args(args, takes, it->name);
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
