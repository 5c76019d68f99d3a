#pragma once
/// @file
/// What the model's analyses and the observer take, declared once: the
/// `piezo` commands, the config's [observer] reader and the Python binding
/// check against these and print them the same way ("allowed: [3, 100000]").

#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

#include "piezo/interval.hpp"

namespace piezo::model::limits {

inline constexpr Interval kSweepPeriods{3.0, 100'000.0};    ///< periods simulated per point
inline constexpr Interval kSweepPoints{1.0, 10'000.0};      ///< points of a one-parameter sweep
inline constexpr Interval kSweepMapPoints{1.0, 1'000.0};    ///< points of a map's second axis
inline constexpr Interval kFitIterations{1.0, 10'000.0};    ///< Levenberg-Marquardt's iterations
inline constexpr Interval kSimulateTolerance{1e-14, 1e-2};  ///< an adaptive integrator's tolerance
inline constexpr Interval kObserverAlpha{0.0, 1.0};         ///< [observer] alpha
inline constexpr Interval kObserverBeta{0.0, 1.0};          ///< [observer] beta
inline constexpr Interval kObserverGate_rad{0.0, 10.0, true};   ///< [observer] gate_rad
inline constexpr Interval kObserverLatency_s{0.0, 1.0};         ///< the drive's output latency
inline constexpr Interval kObserverRampTime_s{0.0, 1.0, true};  ///< a drive sample's ramp

/// "V UNIT (allowed: [a, b] UNIT)" when `allowed` refuses `v`; nothing when it admits it.
[[nodiscard]] inline std::optional<std::string> refused(double v, const Interval& allowed,
                                                        std::string_view unit = "") {
  if (allowed.admits(v)) return std::nullopt;
  const std::string u = unit.empty() ? "" : " " + std::string(unit);
  char value[32];
  std::snprintf(value, sizeof value, "%g", v);
  return std::string(value) + u + " (allowed: " + allowed.text() + u + ")";
}

}  // namespace piezo::model::limits
