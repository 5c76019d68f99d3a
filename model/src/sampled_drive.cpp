#include "piezo/model/sampled_drive.hpp"

#include <algorithm>
#include <functional>
#include <limits>
#include <stdexcept>

namespace piezo::model {

SampledDrive::SampledDrive(std::span<const double> t, std::span<const double> V)
    : t_(t.begin(), t.end()), V_(V.begin(), V.end()) {
  if (t_.size() != V_.size())
    throw std::invalid_argument("drive samples: t and V differ in length");
  if (t_.empty()) throw std::invalid_argument("drive samples: none");
  if (std::adjacent_find(t_.begin(), t_.end(), std::greater_equal<>()) != t_.end()) {
    throw std::invalid_argument("drive samples: times must increase strictly");
  }
}

double SampledDrive::next_breakpoint(double t) const {
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  return it == t_.end() ? std::numeric_limits<double>::infinity() : *it;
}

LinearPiece SampledDrive::piece(double t) const {
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  if (it == t_.begin()) return {t, 0.0, 0.0};
  const auto i = static_cast<std::size_t>(it - t_.begin()) - 1;
  if (i + 1 == t_.size()) return {t_[i], V_[i], 0.0};
  return {t_[i], V_[i], (V_[i + 1] - V_[i]) / (t_[i + 1] - t_[i])};
}

}  // namespace piezo::model
