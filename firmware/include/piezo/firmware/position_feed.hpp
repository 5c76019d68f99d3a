#pragma once
/// @file
/// The latest good sensor reading, from the acquire loop to a controller in
/// the drive loop: one writer, no lock (a sequence lock on atomics). A
/// reader that sees the count change reads the reading published with it,
/// or a newer one, whole: its displacement with its own time.

#include <atomic>
#include <cstdint>

namespace piezo::firmware {

class PositionFeed {
 public:
  struct Reading {
    double displacement_m = 0.0;
    std::int64_t t_ns = 0;  ///< when the sensor answered (the board's clock)
  };

  void publish(double displacement_m, std::int64_t t_ns = 0) {
    const std::uint64_t s = sequence_.load(std::memory_order_relaxed);
    sequence_.store(s + 1, std::memory_order_relaxed);  // odd: being written
    std::atomic_thread_fence(std::memory_order_release);
    displacement_m_.store(displacement_m, std::memory_order_relaxed);
    t_ns_.store(t_ns, std::memory_order_relaxed);
    sequence_.store(s + 2, std::memory_order_release);
  }
  /// Readings published so far.
  [[nodiscard]] std::uint64_t count() const {
    return sequence_.load(std::memory_order_acquire) / 2;
  }
  [[nodiscard]] double displacement_m() const { return latest().displacement_m; }
  /// The latest reading, whole (retried while the writer is in the middle
  /// of one: at most a reading's write, a few nanoseconds).
  [[nodiscard]] Reading latest() const {
    for (;;) {
      const std::uint64_t before = sequence_.load(std::memory_order_acquire);
      Reading r{displacement_m_.load(std::memory_order_relaxed),
                t_ns_.load(std::memory_order_relaxed)};
      std::atomic_thread_fence(std::memory_order_acquire);
      if (before % 2 == 0 && sequence_.load(std::memory_order_relaxed) == before) return r;
    }
  }

 private:
  std::atomic<double> displacement_m_{0.0};
  std::atomic<std::int64_t> t_ns_{0};
  std::atomic<std::uint64_t> sequence_{0};
};

}  // namespace piezo::firmware
