#pragma once
/// @file
/// The board's state (docs/protocol.md, "States"), as piezod keeps it and
/// the wire names it.

#include <string_view>

#include "piezo/name_table.hpp"

namespace piezo::protocol {

enum class BoardState { idle, running, ramping_down, fault };

inline constexpr auto kBoardStateNames =
    names<BoardState>({{BoardState::idle, "idle"},
                       {BoardState::running, "running"},
                       {BoardState::ramping_down, "ramping_down"},
                       {BoardState::fault, "fault"}});

[[nodiscard]] constexpr std::string_view to_string(BoardState s) {
  return kBoardStateNames.name(s);
}

}  // namespace piezo::protocol
