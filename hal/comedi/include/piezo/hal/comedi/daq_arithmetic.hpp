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

/// How many copies of the value due now a write queues, with `queued`
/// samples still waiting and `preload` the depth to keep: one in the steady
/// state (the card took one since the last write), more after late writes
/// (the loop skipped deadlines: the value due now fills their places, as a
/// DAC holds its last value), none when the card's clock runs behind the
/// loop's and the queue is full.
[[nodiscard]] inline std::size_t copies_to_queue(std::size_t queued, std::size_t preload) {
  return queued >= preload ? 0 : preload - queued;
}

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
