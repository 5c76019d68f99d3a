#pragma once
/// @file
/// Simulated digital lines: the amplifier enable goes to every plant's
/// amplifier (one enable for the board's axes),
/// sync pulses are counted, each axis has a trigger line whose history
/// (its rising edges, and when the latest came) is kept, and the e-stop can be pressed at a set
/// time and held, as an operator holds the button: the board latches the press, and its reset is
/// refused until the button is released.

#include <atomic>
#include <limits>
#include <memory>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/sim/plant.hpp"

namespace piezo::hal::sim {

struct SimLinesSettings {
  /// The e-stop is pressed this long after t0 (never by default)...
  double estop_at_s = std::numeric_limits<double>::infinity();
  /// ...and released this long after that (at once by default: the board
  /// still sees the press, at its next poll).
  double estop_hold_s = 0.0;
};

class SimLines final : public DigitalLines {
 public:
  /// `plants` (at least one) outlive the lines.
  SimLines(const SimLinesSettings& settings, std::vector<Plant*> plants, const Clock& clock,
           TimeNs t0);
  SimLines(const SimLinesSettings& settings, Plant& plant, const Clock& clock, TimeNs t0)
      : SimLines(settings, std::vector<Plant*>{&plant}, clock, t0) {}

  Status set_amplifier_enable(bool enabled) override;
  Status set_sync(bool high) override;
  [[nodiscard]] EstopState poll_estop() override;
  bool trip() override;
  /// Refused while the button is down (timed and still held, or pressed).
  bool reset_estop() override;
  [[nodiscard]] bool has_trigger(std::size_t axis) const override { return axis < plants_.size(); }
  Status set_trigger(std::size_t axis, bool high) override;

  /// Presses the e-stop now and for good (any thread): the next poll sees an
  /// edge.
  void press_estop() { estop_pressed_.store(true, std::memory_order_release); }
  [[nodiscard]] long sync_pulses() const { return sync_pulses_.load(); }
  /// Axis `axis`'s trigger line: its rising edges so far, its level, and
  /// when its latest rising edge came [clock ns] (any thread).
  [[nodiscard]] long trigger_edges(std::size_t axis) const { return triggers_[axis].edges.load(); }
  [[nodiscard]] bool trigger_high(std::size_t axis) const { return triggers_[axis].high.load(); }
  [[nodiscard]] TimeNs last_trigger_edge_ns(std::size_t axis) const {
    return triggers_[axis].last_edge_ns.load();
  }
  /// Moves the time origin of estop_at_s, before the run starts: each run
  /// is pressed at its own estop_at_s.
  void set_time_origin(TimeNs t0) {
    t0_ = t0;
    timed_press_seen_ = false;
  }

 private:
  SimLinesSettings settings_;
  std::vector<Plant*> plants_;
  const Clock& clock_;
  TimeNs t0_;
  bool sync_ = false;
  [[nodiscard]] double since_origin_s() const { return to_seconds(clock_.now() - t0_); }
  [[nodiscard]] bool button_down() const;

  bool estop_reported_ = false;
  bool timed_press_seen_ = false;
  std::atomic<bool> estop_pressed_{false};
  std::atomic<long> sync_pulses_{0};
  struct Trigger {
    std::atomic<bool> high{false};
    std::atomic<long> edges{0};
    std::atomic<TimeNs> last_edge_ns{0};
  };
  std::unique_ptr<Trigger[]> triggers_;  ///< one per plant
};

}  // namespace piezo::hal::sim
