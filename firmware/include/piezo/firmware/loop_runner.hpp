#pragma once
/// @file
/// One run of the real-time part: each axis's rings, sensor health and
/// safety supervisor, the drive loop (one tick for every axis) and an
/// acquire loop per sensor line (every line on the same deadlines, each on
/// its own thread: one stalled sensor costs only its line's axes their
/// readings), their threads and real-time set-up, and the virtual clock's
/// backpressure. piezod, the tests and the benchmarks start runs through
/// it; whoever owns it drains the rings.

#include <atomic>
#include <cstddef>
#include <functional>
#include <latch>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "piezo/firmware/acquire_loop.hpp"
#include "piezo/firmware/drive_loop.hpp"
#include "piezo/firmware/realtime_setup.hpp"
#include "piezo/firmware/safety_supervisor.hpp"
#include "piezo/firmware/sensor_health.hpp"
#include "piezo/firmware/spsc_ring.hpp"
#include "piezo/hal/backend.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/displacement_sensor.hpp"
#include "piezo/hal/drive.hpp"

namespace piezo::firmware {

/// The board's: its loops' rates and scheduling.
struct LoopRunnerSettings {
  DriveLoopSettings drive;
  double sensor_rate_hz = 1000.0;
  bool realtime = true;     ///< real-time set-up (false on the virtual clock)
  int priority = 80;        ///< SCHED_FIFO priority of the drive loop (0: do not ask);
                            ///< the acquire loop runs one below
  bool lock_memory = true;  ///< mlockall before the loops start
  double ring_s = 2.0;      ///< each ring holds this much of its loop's output
};

/// One axis of a run: its devices, what it follows and its own limits.
/// Everything referred to outlives the runner.
struct RunAxis {
  hal::Drive& drive;
  hal::DisplacementSensor& sensor;
  DriveProgram& program;  ///< a waveform (WaveformProgram) or a controller reading `feed`
  VoltageLimits limits;
  double period_s = 0.1;  ///< of its waveform, for the sync pulse
  SafetySettings safety;
  /// The sensor's radius and the zero [m] (NaN: the run's first reading),
  /// for the travel window (safety.travel_min_rad/travel_max_rad).
  double r2_m = hal::kDefaultSensorRadius_m;
  double zero_m = std::numeric_limits<double>::quiet_NaN();
  PositionFeed* feed = nullptr;  ///< filled by the acquire loop (may be null)
  std::uint8_t index = 0;        ///< the board's axis (hello.axes), written on its records
  TravelHeading heading = {};    ///< where the run heads, for the travel window
};

class LoopRunner {
 public:
  /// `axes` holds at least one; `remote` (may be null) adds a client's lease
  /// and e-stop to every axis's safety checks.
  LoopRunner(const LoopRunnerSettings& settings, std::vector<RunAxis> axes, hal::Clock& clock,
             hal::DigitalLines& lines, const RemoteControl* remote = nullptr);
  /// Stops and joins a run still under way (the drive ramps down first).
  ~LoopRunner();
  LoopRunner(const LoopRunner&) = delete;
  LoopRunner& operator=(const LoopRunner&) = delete;

  /// Starts the loops' threads, waits until they are set up, then fixes the
  /// time origin a little ahead (so the first deadline is not already
  /// late), tells `on_time_origin` and lets the loops go. `lagging`, on the
  /// virtual clock, holds time back while the consumer is behind (the rings
  /// past half full always do). Returns the time origin.
  hal::TimeNs start(const std::function<void(hal::TimeNs)>& on_time_origin,
                    std::function<bool()> lagging = {});

  /// Asks every axis to ramp down and stop (an operator stop); `at_once`:
  /// 0 V on the next deadline, without the ramp.
  void request_stop(bool at_once = false) {
    if (at_once) stop_now_.store(true);
    stop_.store(true);
  }
  /// Asks one axis (its place in the run) to stop so; the others go on.
  void request_axis_stop(std::size_t axis, bool at_once = false) {
    if (at_once) axes_.at(axis)->stop_now.store(true);
    axes_.at(axis)->stop.store(true);
  }
  /// Every loop has returned.
  [[nodiscard]] bool finished() const {
    return acquire_running_.load(std::memory_order_acquire) == 0;
  }
  /// Waits for every thread; idempotent.
  void join();

  /// Hands every queued sample of one axis to the callbacks (one consumer thread).
  template <typename OnDrive, typename OnSensor>
  void drain(std::size_t axis, OnDrive&& on_drive, OnSensor&& on_sensor) {
    axes_[axis]->drive_ring.drain(on_drive);
    axes_[axis]->sensor_ring.drain(on_sensor);
  }

  [[nodiscard]] std::size_t axis_count() const { return axes_.size(); }
  [[nodiscard]] hal::TimeNs time_origin() const { return t0_; }
  [[nodiscard]] const LoopHealth& drive_health() const { return drive_loop_->health(); }
  /// Every sensor line's loop counts here (cycles: each line's ticks, summed).
  [[nodiscard]] const LoopHealth& sensor_health() const { return sensor_health_; }
  /// How many acquire loops (sensor lines) the run has.
  [[nodiscard]] std::size_t sensor_lines() const { return acquire_loops_.size(); }
  /// Valid after join(): how the run ended (DriveLoop::run), and each axis.
  [[nodiscard]] StopCause cause() const { return cause_; }
  [[nodiscard]] StopCause cause(std::size_t axis) const { return drive_loop_->cause(axis); }
  [[nodiscard]] const OutputOutcome& outcome(std::size_t axis = 0) const {
    return drive_loop_->outcome(axis);
  }
  /// What the real-time set-up did or could not do; complete after join().
  [[nodiscard]] std::vector<std::string> realtime_notes() const;

 private:
  /// What the runner keeps for each axis (atomics: neither copied nor moved).
  struct AxisParts {
    AxisParts(std::size_t drive_capacity, std::size_t sensor_capacity, const SafetySettings& safety,
              hal::TimeNs now)
        : drive_ring(drive_capacity),
          sensor_ring(sensor_capacity),
          supervisor(safety, health, now) {}
    SpscRing<DriveSample> drive_ring;
    SpscRing<SensorSample> sensor_ring;
    SensorHealth health;
    SafetySupervisor supervisor;
    std::atomic<bool> stop{false};      ///< an operator's stop of this axis alone
    std::atomic<bool> stop_now{false};  ///< ... at once, without the ramp
  };

  void set_up_thread(int priority, std::string& note) const;
  [[nodiscard]] bool rings_past_half() const;

  LoopRunnerSettings settings_;
  hal::Clock& clock_;
  const RemoteControl* remote_;  ///< may be null
  std::optional<CpuLatencyRequest> cpu_latency_;
  std::string memory_note_, cpu_note_, drive_note_, acquire_note_;
  std::atomic<bool> stop_{false}, stop_now_{false}, consumer_failed_{false};
  std::atomic<bool> drive_done_{false};
  std::vector<std::unique_ptr<AxisParts>> axes_;
  std::optional<DriveLoop> drive_loop_;
  LoopHealth sensor_health_;
  std::vector<std::unique_ptr<AcquireLoop>> acquire_loops_;  ///< one per sensor line
  std::atomic<std::size_t> acquire_running_{0};  ///< acquire loops not yet returned
  hal::TimeNs t0_ = 0;
  StopCause cause_ = StopCause::none;
  std::optional<std::latch> threads_ready_;  ///< the drive thread and each acquire thread
  std::latch time_origin_fixed_{1};
  std::thread drive_thread_;
  std::vector<std::thread> acquire_threads_;
  bool clock_hooked_ = false;
};

}  // namespace piezo::firmware
