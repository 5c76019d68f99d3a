#pragma once
/// @file
/// The arithmetic of a DAQ card's clocked streams, apart from the card so
/// that it is tested without one: how deep the output's preload is and
/// what latency it adds, how many samples a write puts in to keep it there,
/// and how a sensor's analog output maps onto its measuring range.

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace piezo::hal::comedi {

/// The samples queued ahead of the card's clock: `preload_s` at `rate_hz`,
/// at least two (one playing, one waiting).
[[nodiscard]] inline std::size_t preload_samples(double preload_s, double rate_hz) {
  return std::max<std::size_t>(2, static_cast<std::size_t>(std::lround(preload_s * rate_hz)));
}

/// What the preload adds between a write and its output: every sample waits
/// for the ones queued before it.
[[nodiscard]] inline double preload_latency_s(std::size_t samples, double rate_hz) {
  return static_cast<double>(samples) / rate_hz;
}

/// The drive loop and the card run on two clocks, so the queue's level
/// drifts by their difference (at 100 ppm, a sample in every 10,000), and the
/// card takes samples in bursts (a timer tick, a DMA block), so one reading
/// of the level says little. Every `window` writes, the lowest level seen is
/// compared with the first window's; a drift past a quarter of the preload
/// is corrected by one sample: the value due now queued twice, or left out.
class DriftKeeper {
 public:
  DriftKeeper(std::size_t preload, std::size_t window) : preload_(preload), window_(window) {}

  /// How many copies of the value due now to queue (0, 1 or 2), with
  /// `queued` samples waiting.
  [[nodiscard]] std::size_t copies(std::size_t queued) {
    lowest_ = std::min(lowest_, queued);
    if (++seen_ < window_) return 1;
    const std::size_t lowest = lowest_;
    seen_ = 0;
    lowest_ = static_cast<std::size_t>(-1);
    if (!has_baseline_) {
      baseline_ = lowest;
      has_baseline_ = true;
      return 1;
    }
    const double drift = static_cast<double>(lowest) - static_cast<double>(baseline_);
    if (drift < -0.25 * static_cast<double>(preload_)) return 2;
    if (drift > 0.25 * static_cast<double>(preload_)) return 0;
    return 1;
  }
  /// Starts over (a new stream).
  void reset() { *this = DriftKeeper(preload_, window_); }

 private:
  std::size_t preload_, window_;
  std::size_t seen_ = 0;
  std::size_t lowest_ = static_cast<std::size_t>(-1);
  std::size_t baseline_ = 0;
  bool has_baseline_ = false;
};

/// A sensor's analog output mapped linearly onto its measuring range: the
/// output span's two ends [V] and the distances they stand for [m]. A 4-20
/// mA output across a shunt is the span 4 mA x R to 20 mA x R.
struct AnalogSpan {
  double start_V = 0.0;
  double end_V = 10.0;
  double start_m = 0.0;
  double end_m = 0.01;

  [[nodiscard]] double distance_m(double volts) const {
    return start_m + (volts - start_V) * (end_m - start_m) / (end_V - start_V);
  }
  /// Within the span (either way round): a reading outside is out of range.
  [[nodiscard]] bool admits(double volts) const {
    return volts >= std::min(start_V, end_V) && volts <= std::max(start_V, end_V);
  }
};

/// A raw sample at either end of the converter's scale: the input is
/// saturated (a broken wire, a signal beyond the range), never a reading.
[[nodiscard]] inline bool at_rail(unsigned raw, unsigned maxdata) {
  return raw == 0 || raw >= maxdata;
}

}  // namespace piezo::hal::comedi
