#pragma once
/// @file
/// The board's commands' arguments, declared once (a move's own request is
/// `kMoveFields`, move_request.hpp). Each argument says its wire name, unit,
/// what it allows (an interval whose upper end may be one of the board's
/// limits, named as `hello.limits` names it), its default and one line of
/// doc. The protocol's requests list theirs (`kArgs`: the codecs' and the
/// command table's names), the limit checks take their intervals from here,
/// the board's dictionary (`describe`) lists them, and docs/protocol.md's
/// argument tables are written from them (firmware/protocol/tools/doc_tables.cpp).

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/interval.hpp"

namespace piezo::firmware {

/// What an argument's value is: the wire type a client sends.
enum class ArgumentType : std::uint8_t {
  number,   ///< a float (an integer is taken too)
  integer,  ///< an unsigned integer (an integral float is taken too)
  choice,   ///< one of `choices`' names
  flag,     ///< true or false
  map,      ///< a map (a calibration record), or nil
  text,     ///< any text (an identity such as `board`)
};

struct Argument {
  std::string_view name;
  std::string_view unit;          ///< "" for none
  Interval allowed;               ///< a number's or a count's (a choice: unused)
  std::string_view limit;         ///< the board's limit that is `allowed`'s upper end ("": none)
  std::string_view choices;       ///< a choice's names, comma-separated ("": a number)
  std::string_view default_text;  ///< "required", a value, or where the value comes from
  std::string_view doc;
  ArgumentType type = choices.empty() ? ArgumentType::number : ArgumentType::choice;

  /// `allowed` with the board's limit (the value of `limit`) as its upper end.
  [[nodiscard]] constexpr Interval within(double limit_value) const {
    Interval i = allowed;
    i.max = limit_value;
    return i;
  }
  /// The same argument with another default (a command that fills it in).
  [[nodiscard]] constexpr Argument defaulting(std::string_view text) const {
    Argument a = *this;
    a.default_text = text;
    return a;
  }
};

/// What the docs print as allowed: "(0, V_max]", "[1, inf)", "`forward`, `reverse`".
[[nodiscard]] std::string allowed_text(const Argument& a);

namespace arguments {

inline constexpr double kOpen = std::numeric_limits<double>::infinity();

inline constexpr Argument V0{
    wire_key::V0, "V",        {0.0, kOpen, true},           wire_key::V_max,
    "",           "required", "the sawtooth's peak voltage"};
inline constexpr Argument f{wire_key::f, "Hz",       {0.0, kOpen, true},        wire_key::f_max_hz,
                            "",          "required", "the sawtooth's frequency"};
inline constexpr Argument C_dr{wire_key::C_dr,        "", {0.0, 1.0, true, false}, "", "", "0.95",
                               "commanded duty ratio"};
inline constexpr Argument e_dr{wire_key::e_dr,
                               "",
                               {0.0, 1.0, false, true},
                               "",
                               "",
                               "0.789",
                               "signal-chain factor; the rise fraction D = C_dr·e_dr is in (0, 1)"};
inline constexpr Argument direction{
    "direction",
    "",
    {},
    "",
    "forward, reverse",
    "forward",
    "`reverse`: the mirrored sawtooth (rise fraction 1 − D), the rotor turns backwards"};
inline constexpr Argument duration_s{wire_key::duration_s,     "s", {0.0, kOpen, true},
                                     wire_key::duration_max_s, "",  "required",
                                     "the run's length"};
/// A run's lease when neither the client nor the board's config names one.
inline constexpr double kDefaultLease_s = 0.5;
inline constexpr Argument lease_s{
    wire_key::lease_s,
    "s",
    {0.0, kOpen, true},
    wire_key::lease_max_s,
    "",
    "`hello.lease_s`",
    "the run stops by itself when no `lease` renews it for this long"};
inline constexpr Argument count{
    wire_key::count,
    "",
    {1.0, kOpen},
    "",
    "",
    "required",
    "whole periods, each ending at 0 V; count/f at most `duration_max_s`",
    ArgumentType::integer};
inline constexpr Argument drive_received{
    "drive_received",
    "",
    {0.0, kOpen},
    "",
    "",
    "none",
    "drive samples the client has taken care of; on the virtual clock the board waits while "
    "more than half its recorder, or 20 s of drive samples, are not",
    ArgumentType::integer};
inline constexpr Argument stream{wire_key::stream, "", {}, "", "drive, sensor", "required",
                                 "which recorder"};
inline constexpr Argument first{wire_key::first,
                                "",
                                {0.0, kOpen},
                                "",
                                "",
                                "required",
                                "the first sample's sequence number",
                                ArgumentType::integer};
/// A fetch's size: at most this many samples (the board's recorder serves
/// no more in one frame).
inline constexpr std::uint64_t kMaxFetch = 100'000;
inline constexpr Argument fetch_count{wire_key::count,
                                      "",
                                      {0.0, static_cast<double>(kMaxFetch)},
                                      "",
                                      "",
                                      "required",
                                      "samples, fewer at the recorder's end",
                                      ArgumentType::integer};

// A scan's (`scan`): a constant-velocity move with position-compare triggers.
inline constexpr Argument from_rad{wire_key::from_rad,
                                   "rad",
                                   {-10.0, 10.0},
                                   "",
                                   "",
                                   "required",
                                   "A: where the span at constant velocity begins"};
inline constexpr Argument to_rad{wire_key::to_rad,
                                 "rad",
                                 {-10.0, 10.0},
                                 "",
                                 "",
                                 "required",
                                 "B: where it ends (either side of A)"};
inline constexpr Argument velocity_rad_per_s{
    wire_key::velocity_rad_per_s,
    "rad/s",
    {0.0, kOpen, true},
    "",
    "",
    "required",
    "the mean velocity over A..B, within the axis's `base_rate_rad_per_s` .. "
    "`velocity_max_rad_per_s` (hello, from its calibration)"};
inline constexpr Argument acceleration_s{
    "acceleration_s",
    "s",
    {0.0, 60.0},
    "",
    "",
    "0.2",
    "the run-up before A: from the base rate to the velocity in this time"};
inline constexpr Argument deceleration_s{
    "deceleration_s",
    "s",
    {0.0, 60.0},
    "",
    "",
    "`acceleration_s`",
    "the run-down after B: from the velocity to the base rate in this time"};
inline constexpr Argument trigger_step_rad{
    "trigger_step_rad",
    "rad",
    {0.0, kOpen, true},
    "",
    "",
    "none: no triggers",
    "a pulse each time the measured angle passes start + k·step; at least 5 times the "
    "sensor's peak-to-peak noise (6 standard deviations of a reading)"};
inline constexpr Argument trigger_start_rad{
    "trigger_start_rad", "rad", {-10.0, 10.0}, "", "", "`from_rad`", "the first pulse's position"};
inline constexpr Argument trigger_pulses{"trigger_pulses",
                                         "",
                                         {1.0, 1'000'000.0},
                                         "",
                                         "",
                                         "up to `to_rad`: floor(abs(to_rad − start) / step) + 1",
                                         "positions k = 0 .. pulses - 1",
                                         ArgumentType::integer};
inline constexpr Argument trigger_end_rad{
    "trigger_end_rad",
    "rad",
    {-10.0, 10.0},
    "",
    "",
    "`to_rad`",
    "the last position any pulse may be at: the pulses up to it (PandABox's END; instead of "
    "`trigger_pulses`)"};
inline constexpr Argument trigger_width_s{
    "trigger_width_s",
    "s",
    {0.0, 1.0, true},
    "",
    "",
    "0.001",
    "each pulse's high time (and the least low time before the next)"};
inline constexpr Argument trigger_pre_start_rad{
    "trigger_pre_start_rad",
    "rad",
    {0.0, kOpen},
    "",
    "",
    "0",
    "armed only once the angle was this far before the start"};

}  // namespace arguments
}  // namespace piezo::firmware
