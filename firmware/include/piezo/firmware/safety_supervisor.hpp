#pragma once
/// @file
/// Decides, every drive cycle, whether the drive may go on: an e-stop or
/// failing drive writes disable the amplifier at once (a drive that does not
/// answer cannot ramp); a stale or failing sensor, a stop request or the end
/// of the run ramp the drive to 0 V first.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>

#include "piezo/firmware/angle_zero.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/firmware/sensor_health.hpp"
#include "piezo/firmware/stop_cause.hpp"
#include "piezo/hal/digital_lines.hpp"

namespace piezo::firmware {

struct SafetySettings {
  double sensor_stale_s = 0.1;           ///< longest time without a good reading
  std::uint32_t max_sensor_errors = 20;  ///< consecutive failed reads tolerated
  std::uint32_t max_drive_errors = 3;    ///< consecutive failed writes tolerated
  double ramp_down_V_per_s = 1000.0;     ///< slew of the ramp to 0 V
  /// How long the stop keeps writing 0 V until the drive acknowledges it;
  /// past it the output is reported unconfirmed.
  double stop_confirm_s = 1.0;
  /// The travel window from the zero [rad] (infinite: none): a run or move
  /// whose measured angle leaves it stops with travel_limit.
  double travel_min_rad = -std::numeric_limits<double>::infinity();
  double travel_max_rad = std::numeric_limits<double>::infinity();
  /// A plain run's (timed or steps) stall and plausibility checks over
  /// stall_periods periods (RunGuard); a move has its own, always on unless
  /// the move turns them off.
  bool protect_runs = false;
  int stall_periods = 2;
};

/// Where a run heads, for the travel window: a run that starts at or past
/// an end of the window and heads back inside must not trip that end on
/// the rotor's first periods, which carry it up to a stick stroke the other
/// way (a reverse sawtooth's slow rise turns the rotor forward before the
/// slip takes it back). The end behind the run is held at the start's angle
/// plus that stroke when that is further out; the end ahead stays where it
/// is, so a run heading further out is stopped as before.
struct TravelHeading {
  int direction = 0;          ///< +1 towards larger angles, -1 smaller, 0 unknown (no allowance)
  double excursion_rad = 0.0;  ///< the most a period carries the rotor backwards (a stick stroke)
};

/// What a remote client may do to a running drive, set from the daemon's
/// network thread and read by the drive loop every cycle (lock-free).
struct RemoteControl {
  /// Board-clock time after which the drive stops with link_lost; the
  /// controlling client pushes it forward with each lease renewal.
  std::atomic<hal::TimeNs> lease_deadline{std::numeric_limits<hal::TimeNs>::max()};
  std::atomic<bool> estop{false};  ///< operator e-stop: disable at once
};

enum class SafetyAction : std::uint8_t { run, ramp_down, disable_now };

class SafetySupervisor {
 public:
  SafetySupervisor(const SafetySettings& settings, const SensorHealth& sensor, hal::TimeNs t0)
      : settings_(settings), sensor_(sensor), t0_(t0) {}

  /// One check per drive cycle. The first cause found sticks; an e-stop or a
  /// failing drive overrides a ramp already under way.
  [[nodiscard]] SafetyAction check(hal::TimeNs now, const hal::EstopState& estop,
                                   bool stop_requested, bool duration_elapsed,
                                   bool stop_at_once = false) {
    if (estop.pressed || estop.edge_seen || estop.status != hal::Status::ok ||
        (remote_ != nullptr && remote_->estop.load(std::memory_order_relaxed))) {
      cause_ = StopCause::estop;
      return SafetyAction::disable_now;
    }
    watch_travel();
    if (cause_ == StopCause::none) cause_ = find_cause(now, stop_requested, duration_elapsed);
    // A drive that does not take writes cannot ramp, whatever stopped it;
    // an operator's stop at once skips the ramp (its cause stays its own).
    if (drive_failing() || (stop_at_once && cause_ == StopCause::interrupted)) {
      return SafetyAction::disable_now;
    }
    return cause_ == StopCause::none ? SafetyAction::run : SafetyAction::ramp_down;
  }

  /// Reports the outcome of each drive write.
  void report_drive_write(hal::Status s) {
    drive_errors_ = s == hal::Status::ok ? 0 : drive_errors_ + 1;
  }
  /// Reports the 0 V write before the amplifier is enabled: a drive that
  /// does not take it never gets the amplifier enabled.
  void report_start(hal::Status zero_written) {
    if (zero_written != hal::Status::ok) drive_errors_ = settings_.max_drive_errors;
  }

  /// A fault the drive program found (a move that stalled): the run ramps
  /// down with it as its cause unless another came first.
  void report_program_fault(StopCause c) {
    if (program_fault_ == StopCause::none) program_fault_ = c;
  }

  /// Stops with `c` now unless another cause came first: the drive loop
  /// stopping the board around this axis.
  void stop_now(StopCause c) {
    if (cause_ == StopCause::none) cause_ = c;
  }

  /// Watches the travel window on the readings of `feed`: the angle from
  /// the zero (AngleZero's rule: a NaN zero takes the first reading). Three
  /// readings in a row outside the window stop the run (one wild reading
  /// does not); `heading` widens the end behind the run (TravelHeading).
  void set_travel_feed(const PositionFeed* feed, double zero_m, double r2_m,
                       TravelHeading heading = {}) {
    feed_ = feed;
    travel_zero_ = AngleZero(zero_m);
    r2_m_ = r2_m;
    heading_ = heading;
    travel_min_ = settings_.travel_min_rad;
    travel_max_ = settings_.travel_max_rad;
    seen_ = feed != nullptr ? feed->count() : 0;
  }

  /// Adds a remote client's lease and e-stop to the checks (piezod).
  void set_remote(const RemoteControl* remote) { remote_ = remote; }

  /// Moves the time origin (the first sensor reading is due after it),
  /// before the run starts.
  void set_time_origin(hal::TimeNs t0) { t0_ = t0; }
  /// When the run's duration ends (t0 + duration), before the run starts.
  void set_end(hal::TimeNs end) { end_ = end; }

  [[nodiscard]] StopCause cause() const { return cause_; }
  [[nodiscard]] const SafetySettings& settings() const { return settings_; }

 private:
  [[nodiscard]] StopCause find_cause(hal::TimeNs now, bool stop_requested,
                                     bool duration_elapsed) const {
    if (drive_failing()) return StopCause::drive_fault;
    if (stop_requested) return StopCause::interrupted;
    if (remote_ != nullptr) {
      // A lease that lasted to the run's end covers it: a run that ran its
      // duration completed, even when the loop (late under load, after
      // skipped deadlines) only sees the end once the lease has run out.
      const hal::TimeNs lease = remote_->lease_deadline.load(std::memory_order_relaxed);
      if (now > lease && !(duration_elapsed && lease >= end_)) return StopCause::link_lost;
    }
    const hal::TimeNs last_good = std::max(sensor_.last_good.load(std::memory_order_acquire), t0_);
    if (hal::to_seconds(now - last_good) > settings_.sensor_stale_s ||
        sensor_.consecutive_errors.load(std::memory_order_relaxed) >= settings_.max_sensor_errors) {
      return StopCause::sensor_fault;
    }
    if (program_fault_ != StopCause::none) return program_fault_;
    if (outside_ >= kOutsideReadings) return StopCause::travel_limit;
    if (duration_elapsed) return StopCause::completed;
    return StopCause::none;
  }

  [[nodiscard]] bool drive_failing() const { return drive_errors_ >= settings_.max_drive_errors; }

  void watch_travel() {
    if (feed_ == nullptr || feed_->count() == seen_) return;
    seen_ = feed_->count();
    const double d = feed_->displacement_m();
    travel_zero_.offer(d);
    const double theta = travel_zero_.angle_rad(d, r2_m_);
    if (!heading_taken_) {  // the run's first reading: where it starts from
      heading_taken_ = true;
      if (heading_.direction < 0) travel_max_ = std::max(travel_max_, theta + heading_.excursion_rad);
      if (heading_.direction > 0) travel_min_ = std::min(travel_min_, theta - heading_.excursion_rad);
    }
    const bool inside = theta >= travel_min_ && theta <= travel_max_;
    outside_ = inside ? 0 : outside_ + 1;
  }

  static constexpr int kOutsideReadings = 3;

  SafetySettings settings_;
  const SensorHealth& sensor_;
  hal::TimeNs t0_;
  hal::TimeNs end_ = std::numeric_limits<hal::TimeNs>::max();
  const RemoteControl* remote_ = nullptr;
  StopCause program_fault_ = StopCause::none;
  const PositionFeed* feed_ = nullptr;  ///< readings for the travel window (null: none)
  std::uint64_t seen_ = 0;
  AngleZero travel_zero_{0.0};
  double r2_m_ = 1.0;
  TravelHeading heading_;
  bool heading_taken_ = false;
  double travel_min_ = -std::numeric_limits<double>::infinity();  ///< this run's window
  double travel_max_ = std::numeric_limits<double>::infinity();
  int outside_ = 0;  ///< readings in a row outside the travel window
  StopCause cause_ = StopCause::none;
  std::uint32_t drive_errors_ = 0;
};

}  // namespace piezo::firmware
