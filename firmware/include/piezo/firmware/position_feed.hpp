#pragma once
/// @file
/// The latest good sensor reading, from the acquire loop to a controller in
/// the drive loop: one writer, no lock (a sequence lock on atomics, every
/// access sequentially consistent: one order of all of them, so a reader
/// that saw the same even count before and after its reads saw no write
/// between; no fences, which ThreadSanitizer cannot follow). A reader that
/// sees the count change reads the reading published with it, or a newer
/// one, whole: its displacement with its own time.

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
    const std::uint64_t s = sequence_.load();
    sequence_.store(s + 1);  // odd: being written
    displacement_m_.store(displacement_m);
    t_ns_.store(t_ns);
    sequence_.store(s + 2);
  }
  /// Readings published so far.
  [[nodiscard]] std::uint64_t count() const { return sequence_.load() / 2; }
  [[nodiscard]] double displacement_m() const { return latest().displacement_m; }
  /// The latest reading, whole (retried while the writer is in the middle
  /// of one: at most a reading's write, a few nanoseconds).
  [[nodiscard]] Reading latest() const {
    for (;;) {
      const std::uint64_t before = sequence_.load();
      const Reading r{displacement_m_.load(), t_ns_.load()};
      if (before % 2 == 0 && sequence_.load() == before) return r;
    }
  }

 private:
  std::atomic<double> displacement_m_{0.0};
  std::atomic<std::int64_t> t_ns_{0};
  std::atomic<std::uint64_t> sequence_{0};
};

}  // namespace piezo::firmware
