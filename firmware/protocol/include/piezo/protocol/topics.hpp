#pragma once
/// @file
/// The stream's topics (docs/protocol.md, "Stream"), each written once: the
/// board publishes under them, `describe` lists them, clients subscribe by them.

#include <array>
#include <string_view>

#include "piezo/firmware/wire_keys.hpp"

namespace piezo::protocol::topic {

inline constexpr std::string_view drive = wire_key::drive;      ///< drive sample frames
inline constexpr std::string_view sensor = wire_key::sensor;    ///< sensor sample frames
inline constexpr std::string_view state = wire_key::state;      ///< every change of state
inline constexpr std::string_view health = "health";            ///< every 250 ms
inline constexpr std::string_view moved = wire_key::moved;      ///< an axis moved at rest
inline constexpr std::string_view trigger = wire_key::trigger;  ///< a scan's trigger pulse

inline constexpr std::array kAll{drive, sensor, state, health, moved, trigger};

}  // namespace piezo::protocol::topic
