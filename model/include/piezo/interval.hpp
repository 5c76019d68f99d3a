#pragma once
/// @file
/// An allowed interval of a number, with open or closed ends: the config
/// readers and the declared requests (a move's fields) say what they accept
/// with one, and every error and doc row prints it the same way.

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace piezo {

struct Interval {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  bool max_open = false;

  [[nodiscard]] constexpr bool admits(double v) const {
    if (v != v) return false;  // NaN
    const bool above_min = min_open ? v > min : v >= min;
    const bool below_max = max_open ? v < max : v <= max;
    return above_min && below_max;
  }

  /// "[a, b]", "(a, b]", ...: numbers as %g prints them ("inf" for no bound).
  [[nodiscard]] std::string text() const {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s%g, %g%s", min_open ? "(" : "[", min, max,
                  max_open ? ")" : "]");
    return buf;
  }
};

}  // namespace piezo
