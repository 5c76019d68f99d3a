#pragma once
/// @file
/// A move's request, declared once. Each field of `MoveRequest` has one row
/// in `kMoveFields`: its name (the protocol's `move_to` argument, the key in
/// a config's [move] section and the Python keyword), `piezo move`'s
/// option, its unit, its allowed interval and one line of doc; its default
/// is the struct's initialiser. The wire codec, piezod's command table,
/// `piezo move`'s options, the [move] reader, `check_move` and the docs'
/// tests all walk this table, so a new option is one row here plus the
/// controller's use of it.

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/interval.hpp"
#include "piezo/name_table.hpp"

namespace piezo::firmware {

/// From which side the move's last steps and its fine servo arrive.
enum class Approach : std::uint8_t {
  either = 0,   ///< whichever side the rotor is on
  forward = 1,  ///< always from below the target (overshoot goes back past it and comes again)
  reverse = 2,  ///< always from above
};

inline constexpr auto kApproachNames = names<Approach>(
    {{Approach::either, "either"}, {Approach::forward, "forward"}, {Approach::reverse, "reverse"}});

/// Coarse steps over which progress is judged, at most.
inline constexpr std::uint64_t kMaxStallSteps = 16;

/// What a move asks for besides its waveform (the defaults are the
/// protocol's, the CLI's and the config's).
struct MoveRequest {
  double target_rad = 0.0;
  double tolerance_rad = 25e-6;
  double settle_s = 0.1;
  double timeout_s = 30.0;
  double hold_s = 0.0;
  bool protect = true;
  std::uint64_t stall_steps = 2;
  Approach approach = Approach::either;
};

/// One field of a move request: everything each layer says of it.
struct MoveField {
  using Member = std::variant<double MoveRequest::*, std::uint64_t MoveRequest::*,
                              bool MoveRequest::*, Approach MoveRequest::*>;
  std::string_view name;    ///< wire argument, [move] key, Python keyword
  std::string_view option;  ///< `piezo move`'s option; for a flag, the one that clears it
  std::string_view unit;    ///< "" for none
  Interval allowed;         ///< numbers and counts (a flag or a choice: unused)
  std::string_view doc;
  Member member;
  bool required = false;        ///< no default: not a config key, always on the wire
  std::string_view limit = {};  ///< the board's limit that is `allowed`'s upper end ("": none)
};

inline constexpr double kNoBound = std::numeric_limits<double>::infinity();

inline constexpr std::array<MoveField, 8> kMoveFields{{
    {wire_key::target_rad,
     "--to",
     "rad",
     {-10.0, 10.0},
     "target angle from the board's zero",
     &MoveRequest::target_rad,
     true},
    {wire_key::tolerance_rad,
     "--tolerance",
     "rad",
     {0.0, 0.1, true},
     "on target within this (and at least what the sensor resolves)",
     &MoveRequest::tolerance_rad},
    {"settle_s",
     "--settle",
     "s",
     {0.0, 10.0},
     "how long the angle stays within the tolerance at 0 V before the move is on target",
     &MoveRequest::settle_s},
    {"timeout_s",
     "--timeout",
     "s",
     {0.0, kNoBound, true},
     "give up after this long (at most the board's duration_max_s)",
     &MoveRequest::timeout_s,
     false,
     wire_key::duration_max_s},
    {wire_key::hold_s,
     "--hold",
     "s",
     {0.0, kNoBound, false, true},
     "keep the fine servo on this long once on target, then release to 0 V (below timeout_s)",
     &MoveRequest::hold_s},
    {"protect",
     "--no-protect",
     "",
     {},
     "the board's stall and sensor-plausibility checks",
     &MoveRequest::protect},
    {"stall_steps",
     "--stall-steps",
     "",
     {1.0, static_cast<double>(kMaxStallSteps)},
     "coarse steps without progress that end the move `stalled`",
     &MoveRequest::stall_steps},
    {"approach",
     "--approach",
     "",
     {},
     "the side the last steps and the fine servo arrive from: either, forward (from below), "
     "reverse (from above)",
     &MoveRequest::approach},
}};

/// The field a request names `name` (nullptr: none).
[[nodiscard]] const MoveField* find_move_field(std::string_view name);

/// The field's default (the struct's initialiser) as the docs print it:
/// numbers as %g, a flag as true/false, a choice by name.
[[nodiscard]] std::string default_text(const MoveField& field);

/// What the field allows, as the docs and the errors print it: an
/// interval, "1..16" for a count, "true/false", or the choice's names.
[[nodiscard]] std::string allowed_text(const MoveField& field);

}  // namespace piezo::firmware
