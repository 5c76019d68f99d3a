#pragma once
/// @file
/// The protocol's keys that more than one declaration uses: each written
/// here once, and taken by name everywhere else (request arguments, the
/// board's limits, the field lists of replies and events, the daemon, the
/// host's readers), so a misspelled key does not compile. A key that only
/// one field list uses is written in that list. tests/docs/wire_keys_test.py
/// counts: outside tests, each key is one literal in the C++ of the wire.

#include <string_view>

namespace piezo::wire_key {

inline constexpr std::string_view angle_rad = "angle_rad";
inline constexpr std::string_view axes = "axes";
inline constexpr std::string_view axis = "axis";
inline constexpr std::string_view board = "board";
inline constexpr std::string_view board_id = "board_id";
inline constexpr std::string_view board_ns = "board_ns";
inline constexpr std::string_view C_dr = "C_dr";
inline constexpr std::string_view calibrated = "calibrated";
inline constexpr std::string_view calibration = "calibration";
inline constexpr std::string_view calibration_progress = "calibration_progress";
inline constexpr std::string_view cause = "cause";
inline constexpr std::string_view clock = "clock";
inline constexpr std::string_view controller = "controller";
inline constexpr std::string_view count = "count";
inline constexpr std::string_view D = "D";
inline constexpr std::string_view drive = "drive";
inline constexpr std::string_view duration_max_s = "duration_max_s";
inline constexpr std::string_view duration_s = "duration_s";
inline constexpr std::string_view e_dr = "e_dr";
inline constexpr std::string_view errors = "errors";
inline constexpr std::string_view f = "f";
inline constexpr std::string_view f_hz = "f_hz";
inline constexpr std::string_view f_max_hz = "f_max_hz";
inline constexpr std::string_view fault = "fault";
inline constexpr std::string_view first = "first";
inline constexpr std::string_view frequencies = "frequencies";
inline constexpr std::string_view from_rad = "from_rad";
inline constexpr std::string_view histogram_us = "histogram_us";
inline constexpr std::string_view hold_s = "hold_s";
inline constexpr std::string_view id = "id";
inline constexpr std::string_view k = "k";
inline constexpr std::string_view late = "late";
inline constexpr std::string_view lease_max_s = "lease_max_s";
inline constexpr std::string_view lease_s = "lease_s";
inline constexpr std::string_view model = "model";
inline constexpr std::string_view move = "move";
inline constexpr std::string_view moved = "moved";
inline constexpr std::string_view moved_rad = "moved_rad";
inline constexpr std::string_view moves = "moves";
inline constexpr std::string_view name = "name";
inline constexpr std::string_view noise_m = "noise_m";
inline constexpr std::string_view noise_rad = "noise_rad";
inline constexpr std::string_view now = "now";
inline constexpr std::string_view output = "output";
inline constexpr std::string_view position = "position";
inline constexpr std::string_view position_rad = "position_rad";
inline constexpr std::string_view protocol = "protocol";
inline constexpr std::string_view pulses = "pulses";
inline constexpr std::string_view r2_m = "r2_m";
inline constexpr std::string_view rest = "rest";
inline constexpr std::string_view run = "run";
inline constexpr std::string_view scan = "scan";
inline constexpr std::string_view scans = "scans";
inline constexpr std::string_view sensor = "sensor";
inline constexpr std::string_view slew_V_per_s = "slew_V_per_s";
inline constexpr std::string_view state = "state";
inline constexpr std::string_view step_fractions = "step_fractions";
inline constexpr std::string_view steps_per_point = "steps_per_point";
inline constexpr std::string_view stop_cause = "stop_cause";
inline constexpr std::string_view stream = "stream";
inline constexpr std::string_view summary = "summary";
inline constexpr std::string_view t0_ns = "t0_ns";
inline constexpr std::string_view target_rad = "target_rad";
inline constexpr std::string_view targets = "targets";
inline constexpr std::string_view to_rad = "to_rad";
inline constexpr std::string_view tolerance_rad = "tolerance_rad";
inline constexpr std::string_view trigger = "trigger";
inline constexpr std::string_view triggers = "triggers";
inline constexpr std::string_view V0 = "V0";
inline constexpr std::string_view V_max = "V_max";
inline constexpr std::string_view V_min = "V_min";
inline constexpr std::string_view velocity_rad_per_s = "velocity_rad_per_s";
inline constexpr std::string_view version = "version";
inline constexpr std::string_view zero_displacement_m = "zero_displacement_m";

}  // namespace piezo::wire_key
