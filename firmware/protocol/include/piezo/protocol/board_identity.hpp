#pragma once
/// @file
/// Which requests name the board start they were meant for (docs/protocol.md,
/// "A board's identity"). Every board start has its own identity (`hello`'s
/// `board_id`); a request that names another one is refused (`stale_board`)
/// and does nothing, so a request queued towards a board that restarted
/// never acts on the new one. `hello` names none (it is how a client learns
/// the identity), nor does `estop` (an e-stop is honoured whoever sent it).

#include <string_view>

namespace piezo::protocol {

/// True when `cmd` takes the optional argument `board`.
[[nodiscard]] constexpr bool names_board(std::string_view cmd) {
  return cmd != "hello" && cmd != "estop";
}

}  // namespace piezo::protocol
