#include "piezo/firmware/position_compare.hpp"

namespace piezo::firmware {

void PositionCompare::on_angle(double angle_rad, std::int64_t reading_ns) {
  const double ahead_of_start = s_.direction * (angle_rad - s_.start_rad);
  if (!armed_) {
    if (ahead_of_start > -s_.pre_start_rad) return;
    armed_ = true;
  }
  bool first = true;
  while (next_k_ < s_.pulses && queued_ < kQueue &&
         s_.direction * (angle_rad - position_of(next_k_)) >= 0.0) {
    TriggerPulse& p = queue_[static_cast<std::size_t>((head_ + queued_) % kQueue)];
    p = {next_k_, position_of(next_k_), angle_rad, reading_ns, 0.0, !first || queued_ > 0 || high_};
    ++queued_;
    ++next_k_;
    first = false;
  }
}

bool PositionCompare::tick(double t, bool& level, TriggerPulse& fired) {
  if (high_ && t >= high_until_) {
    high_ = false;
    low_until_ = t + s_.width_s;
  }
  bool rose = false;
  if (!high_ && queued_ > 0 && t >= low_until_) {
    fired = queue_[static_cast<std::size_t>(head_)];
    fired.edge_s = t;
    head_ = (head_ + 1) % kQueue;
    --queued_;
    high_ = true;
    high_until_ = t + s_.width_s;
    rose = true;
  }
  level = high_;
  return rose;
}

}  // namespace piezo::firmware
