#pragma once
/// @file
/// The latest good sensor reading, from the acquire loop to a controller in
/// the drive loop: one writer, wait-free, no lock. A reader that sees the
/// count change reads the displacement published with it or a newer one.

#include <atomic>
#include <cstdint>

namespace piezo::firmware {

class PositionFeed {
 public:
  void publish(double displacement_m) {
    displacement_m_.store(displacement_m, std::memory_order_relaxed);
    count_.fetch_add(1, std::memory_order_release);
  }
  [[nodiscard]] std::uint64_t count() const { return count_.load(std::memory_order_acquire); }
  [[nodiscard]] double displacement_m() const {
    return displacement_m_.load(std::memory_order_relaxed);
  }

 private:
  std::atomic<double> displacement_m_{0.0};
  std::atomic<std::uint64_t> count_{0};
};

}  // namespace piezo::firmware
