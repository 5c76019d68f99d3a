#include "piezo/firmware/rest_watch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace piezo::firmware {

double noise_of_readings(const double* readings, std::size_t n) {
  if (n < 3) return std::numeric_limits<double>::quiet_NaN();
  std::array<double, RestWatch::kWindow> steps{};
  const std::size_t m = std::min(n - 1, steps.size());
  for (std::size_t i = 0; i < m; ++i) steps[i] = std::abs(readings[i + 1] - readings[i]);
  std::nth_element(steps.begin(), steps.begin() + static_cast<long>(m / 2),
                   steps.begin() + static_cast<long>(m));
  // For Gaussian noise the difference of two readings has sigma*sqrt(2),
  // and its absolute value's median is 0.6745 of that.
  return steps[m / 2] / (0.6745 * std::sqrt(2.0));
}

void RestWatch::begin() {
  count_ = 0;
  reference_m_.reset();
  reported_m_.reset();
  moved_ = false;
}

double RestWatch::at(std::size_t back) const {
  return readings_[(count_ - 1 - back) % kWindow];
}

std::optional<double> RestWatch::position_m() const {
  if (count_ < kMean) return std::nullopt;
  double sum = 0.0;
  for (std::size_t i = 0; i < kMean; ++i) sum += at(i);
  return sum / static_cast<double>(kMean);
}

std::optional<double> RestWatch::noise_m() const {
  const std::size_t n = std::min(count_, kWindow);
  if (n < 3) return std::nullopt;
  std::array<double, kWindow> ordered{};
  for (std::size_t i = 0; i < n; ++i) ordered[i] = at(n - 1 - i);
  return noise_of_readings(ordered.data(), n);
}

double RestWatch::threshold_m() const {
  return std::max(kMovedNoises * noise_m().value_or(0.0), kMovedFloor_m);
}

bool RestWatch::settled() const {
  double lo = at(0), hi = at(0);
  for (std::size_t i = 1; i < kMean; ++i) {
    lo = std::min(lo, at(i));
    hi = std::max(hi, at(i));
  }
  return hi - lo <= threshold_m();
}

double RestWatch::since_rest_m() const {
  const auto p = position_m();
  return reference_m_ && p ? *p - *reference_m_ : 0.0;
}

std::optional<RestWatch::Move> RestWatch::add(double displacement_m) {
  readings_[count_ % kWindow] = displacement_m;
  ++count_;
  const auto p = position_m();
  if (!p) return std::nullopt;
  if (!reference_m_) {
    reference_m_ = reported_m_ = p;
    return std::nullopt;
  }
  if (std::abs(*p - *reported_m_) <= threshold_m() || !settled()) return std::nullopt;
  const Move move{*p - *reported_m_, *p - *reference_m_};
  reported_m_ = p;
  moved_ = true;
  return move;
}

}  // namespace piezo::firmware
