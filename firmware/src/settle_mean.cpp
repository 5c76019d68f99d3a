#include "piezo/firmware/settle_mean.hpp"

#include <algorithm>

namespace piezo::firmware {

void SettleMean::start(int n) {
  n_ = std::clamp(n, 1, kMax);
  count_ = 0;
  sum_ = 0.0;
}

bool SettleMean::add(double displacement_m) {
  ring_[static_cast<std::size_t>(next_)] = displacement_m;
  next_ = (next_ + 1) % kRing;
  sum_ += displacement_m;
  if (++count_ > n_) sum_ -= ring_[static_cast<std::size_t>((next_ - 1 - n_ + kRing) % kRing)];
  // The ring's readings are what a widened mean can take again.
  count_ = std::min(count_, kRing);
  return count_ >= n_;
}

bool SettleMean::widen() {
  if (n_ >= kMax) return false;
  n_ = std::min(2 * n_, kMax);
  const int held = std::min(count_, n_);
  sum_ = 0.0;
  for (int i = 1; i <= held; ++i) {
    sum_ += ring_[static_cast<std::size_t>((next_ - i + kRing) % kRing)];
  }
  count_ = held;
  return true;
}

}  // namespace piezo::firmware
