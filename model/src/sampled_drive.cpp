#include "piezo/model/sampled_drive.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

namespace piezo::model {

namespace {

/// Slopes this close (relative) continue one line: a sampled ramp's differ
/// by rounding only.
constexpr double kCollinear = 1e-9;

}  // namespace

SampledDrive::SampledDrive(std::span<const double> t, std::span<const double> V, double ramp_time) {
  if (!(ramp_time > 0.0)) throw std::invalid_argument("drive samples: ramp time must be > 0");
  if (t.size() != V.size()) throw std::invalid_argument("drive samples: t and V differ in length");
  if (t.empty()) throw std::invalid_argument("drive samples: none");
  if (std::adjacent_find(t.begin(), t.end(), std::greater_equal<>()) != t.end()) {
    throw std::invalid_argument("drive samples: times must increase strictly");
  }
  // Each sample starts a ramp from the output it finds (a ramp cut short by
  // an early next sample ends where it got to), then a hold.
  auto add = [&](double t0, double V0, double slope) {
    if (!pieces_.empty()) {
      LinearPiece& last = pieces_.back();
      const double tolerance = kCollinear * std::max(std::abs(last.slope), std::abs(slope));
      if (std::abs(last.slope - slope) <= tolerance) return;  // the same line goes on
    }
    start_.push_back(t0);
    pieces_.push_back({t0, V0, slope});
  };
  add(-std::numeric_limits<double>::infinity(), 0.0, 0.0);
  pieces_.back().t0 = 0.0;
  double output = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double span =
        i + 1 < t.size() ? t[i + 1] - t[i] : std::numeric_limits<double>::infinity();
    const double slope = (V[i] - output) / ramp_time;
    add(t[i], output, slope);
    if (span > ramp_time) add(t[i] + ramp_time, V[i], 0.0);
    output += (V[i] - output) * std::min(1.0, span / ramp_time);
  }
}

double SampledDrive::next_breakpoint(double t) const {
  const auto it = std::upper_bound(start_.begin(), start_.end(), t);
  return it == start_.end() ? std::numeric_limits<double>::infinity() : *it;
}

PieceSpan SampledDrive::span(double t) const {
  const auto it = std::upper_bound(start_.begin(), start_.end(), t);
  return {pieces_[static_cast<std::size_t>(it - start_.begin()) - 1],
          it == start_.end() ? std::numeric_limits<double>::infinity() : *it};
}

LinearPiece SampledDrive::piece(double t) const {
  const auto it = std::upper_bound(start_.begin(), start_.end(), t);
  return pieces_[static_cast<std::size_t>(it - start_.begin()) - 1];
}

}  // namespace piezo::model
