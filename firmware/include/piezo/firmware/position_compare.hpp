#pragma once
/// @file
/// Position compare: a scan's trigger pulses at measured angles, as
/// PandABox's PCOMP block and the closed-loop stages' position triggers
/// fire them. Pulse k is due when the filtered measured angle first passes
/// start + k * step in the scan's direction; each k fires once, whatever the
/// angle does afterwards (the rotor of a stick-slip motor slips back a
/// little every period: a position is never passed "again"). Nothing is
/// armed until the angle has been at least `pre_start` before start.
///
/// A reading that passes several positions at once (a step shorter than
/// one reading's travel) queues them all: each goes out as its own pulse,
/// `width` high and `width` low after the one before, and counts as late.
/// Nothing is dropped: when the queue is full, the positions wait for the
/// next reading (late too).
///
/// Pure and fixed-size: no allocation, lock or throw; the drive loop calls it.

#include <array>
#include <cstdint>

namespace piezo::firmware {

struct CompareSettings {
  double start_rad = 0.0;      ///< the first position (from the axis's zero)
  double step_rad = 1e-3;      ///< between positions (> 0)
  std::uint32_t pulses = 1;    ///< positions k = 0 .. pulses - 1
  double width_s = 1e-3;       ///< each pulse's high time, and the least low time after it
  int direction = 1;           ///< +1: the angle rising passes them; -1: falling
  double pre_start_rad = 0.0;  ///< armed once the angle was this far before start
};

/// A pulse as it went out.
struct TriggerPulse {
  std::uint32_t k = 0;
  double position_rad = 0.0;    ///< start + k * step * direction
  double angle_rad = 0.0;       ///< the filtered angle that passed it
  std::int64_t reading_ns = 0;  ///< that reading's time (the board's clock)
  double edge_s = 0.0;          ///< its rising edge [s from the run's time origin]
  bool late = false;  ///< not the only position its reading passed, or it waited for another pulse
};

class PositionCompare {
 public:
  static constexpr int kQueue = 64;

  explicit PositionCompare(const CompareSettings& settings) : s_(settings) {}

  /// A new filtered angle, read at `reading_ns`: queues every position it passed.
  void on_angle(double angle_rad, std::int64_t reading_ns);
  /// Every drive tick at t [s]: the line's level wanted now; when a pulse's
  /// edge rises at this tick it is written to `fired` and true is returned.
  bool tick(double t, bool& level, TriggerPulse& fired);

  [[nodiscard]] bool armed() const { return armed_; }
  /// Every position has fired and the last pulse has ended.
  [[nodiscard]] bool done() const { return next_k_ == s_.pulses && queued_ == 0 && !high_; }
  /// No pulse is queued or high.
  [[nodiscard]] bool idle() const { return queued_ == 0 && !high_; }
  [[nodiscard]] std::uint32_t next_k() const { return next_k_; }
  [[nodiscard]] double position_of(std::uint32_t k) const {
    return s_.start_rad + s_.direction * s_.step_rad * static_cast<double>(k);
  }
  [[nodiscard]] const CompareSettings& settings() const { return s_; }

 private:
  CompareSettings s_;
  bool armed_ = false;
  std::uint32_t next_k_ = 0;  ///< the next position to pass
  std::array<TriggerPulse, kQueue> queue_{};
  int head_ = 0, queued_ = 0;
  bool high_ = false;
  double high_until_ = 0.0, low_until_ = -1.0;
};

}  // namespace piezo::firmware
