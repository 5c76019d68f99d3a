#pragma once
/// @file
/// How a run left the drive's output, in a word (a run summary's
/// `output.state`), with the names the wire and the logs give it.

#include <cstdint>
#include <string_view>

#include "piezo/name_table.hpp"

namespace piezo::firmware {

enum class OutputState : std::uint8_t {
  confirmed,           ///< 0 V acknowledged, enable dropped
  output_unconfirmed,  ///< 0 V never acknowledged
  enable_unconfirmed,  ///< 0 V acknowledged, but the enable line's write failed
};
inline constexpr auto kOutputStateNames =
    names<OutputState>({{OutputState::confirmed, "confirmed"},
                        {OutputState::output_unconfirmed, "output_unconfirmed"},
                        {OutputState::enable_unconfirmed, "enable_unconfirmed"}});

[[nodiscard]] constexpr std::string_view to_string(OutputState s) {
  return kOutputStateNames.name(s);
}

}  // namespace piezo::firmware
