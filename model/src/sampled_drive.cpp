#include "piezo/model/sampled_drive.hpp"

#include <algorithm>
#include <functional>
#include <limits>
#include <stdexcept>

namespace piezo::model {

SampledDrive::SampledDrive(std::span<const double> t, std::span<const double> V, double ramp_time)
    : t_(t.begin(), t.end()), V_(V.begin(), V.end()), ramp_time_(ramp_time) {
  if (!(ramp_time > 0.0)) throw std::invalid_argument("drive samples: ramp time must be > 0");
  if (t_.size() != V_.size())
    throw std::invalid_argument("drive samples: t and V differ in length");
  if (t_.empty()) throw std::invalid_argument("drive samples: none");
  if (std::adjacent_find(t_.begin(), t_.end(), std::greater_equal<>()) != t_.end()) {
    throw std::invalid_argument("drive samples: times must increase strictly");
  }
  from_.resize(t_.size());
  double output = 0.0;
  for (std::size_t i = 0; i < t_.size(); ++i) {
    from_[i] = output;
    const double span = i + 1 < t_.size() ? t_[i + 1] - t_[i] : ramp_time_;
    output += (V_[i] - output) * std::min(1.0, span / ramp_time_);
  }
}

double SampledDrive::next_breakpoint(double t) const {
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  if (it != t_.begin()) {
    const double ramp_end = *(it - 1) + ramp_time_;
    if (t < ramp_end && (it == t_.end() || ramp_end < *it)) return ramp_end;
  }
  return it == t_.end() ? std::numeric_limits<double>::infinity() : *it;
}

LinearPiece SampledDrive::piece(double t) const {
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  if (it == t_.begin()) return {t, 0.0, 0.0};
  const auto i = static_cast<std::size_t>(it - t_.begin()) - 1;
  if (t < t_[i] + ramp_time_) return {t_[i], from_[i], (V_[i] - from_[i]) / ramp_time_};
  return {t, V_[i], 0.0};
}

}  // namespace piezo::model
