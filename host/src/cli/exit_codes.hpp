#pragma once
// What `piezo` exits with, for every command (docs/commands.md says when).

namespace piezo::host {

inline constexpr int kExitFailed = 1;         ///< the command ran and failed
inline constexpr int kExitBadInput = 2;       ///< refused before anything ran: options, config
inline constexpr int kExitInterrupted = 130;  ///< the shell's code for SIGINT

}  // namespace piezo::host
