#pragma once
/// @file
/// One run of the real-time part: the rings, the sensor health, the safety
/// supervisor, the drive and acquire loops, their threads and real-time
/// set-up, and the virtual clock's backpressure. piezod, the tests and the
/// benchmarks start runs through it; whoever owns it drains the rings.

#include <atomic>
#include <functional>
#include <latch>
#include <limits>
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
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {

struct LoopRunnerSettings {
  DriveLoopSettings drive;
  SafetySettings safety;
  double sensor_rate_hz = 1000.0;
  bool realtime = true;     ///< real-time set-up (false on the virtual clock)
  int priority = 80;        ///< SCHED_FIFO priority of the drive loop (0: do not ask);
                            ///< the acquire loop runs one below
  bool lock_memory = true;  ///< mlockall before the loops start
  double ring_s = 2.0;      ///< each ring holds this much of its loop's output
  /// The sensor's radius and the zero [m] (NaN: the run's first reading),
  /// for the travel window (safety.travel_min_rad/travel_max_rad).
  double r2_m = hal::kDefaultSensorRadius_m;
  double zero_m = std::numeric_limits<double>::quiet_NaN();
};

/// The devices a run works with; all outlive the runner.
struct LoopDevices {
  hal::Clock& clock;
  hal::Drive& drive;
  hal::DisplacementSensor& sensor;
  hal::DigitalLines& lines;
};

class LoopRunner {
 public:
  /// `remote` (may be null) adds a client's lease and e-stop to the safety
  /// checks; `waveform` outlives the runner.
  LoopRunner(const LoopRunnerSettings& settings, const model::Excitation& waveform,
             LoopDevices devices, const RemoteControl* remote = nullptr,
             PositionFeed* feed = nullptr);
  /// A run that follows `program` (e.g. a MoveController reading `feed`,
  /// which the acquire loop fills); both outlive the runner.
  LoopRunner(const LoopRunnerSettings& settings, DriveProgram& program, LoopDevices devices,
             const RemoteControl* remote, PositionFeed* feed);
  /// Stops and joins a run still under way (the drive ramps down first).
  ~LoopRunner();
  LoopRunner(const LoopRunner&) = delete;
  LoopRunner& operator=(const LoopRunner&) = delete;

  /// Starts both loop threads, waits until they are set up, then fixes the
  /// time origin a little ahead (so the first deadline is not already
  /// late), tells `on_time_origin` and lets the loops go. `lagging`, on the
  /// virtual clock, holds time back while the consumer is behind (the rings
  /// past half full always do). Returns the time origin.
  hal::TimeNs start(const std::function<void(hal::TimeNs)>& on_time_origin,
                    std::function<bool()> lagging = {});

  /// Asks the drive to ramp down and stop (an operator stop).
  void request_stop() { stop_.store(true); }
  /// Both loops have returned.
  [[nodiscard]] bool finished() const { return acquire_done_.load(std::memory_order_acquire); }
  /// Waits for both threads; idempotent.
  void join();

  /// Hands every queued sample to the callbacks (one consumer thread).
  template <typename OnDrive, typename OnSensor>
  void drain(OnDrive&& on_drive, OnSensor&& on_sensor) {
    drive_ring_.drain(on_drive);
    sensor_ring_.drain(on_sensor);
  }

  [[nodiscard]] hal::TimeNs time_origin() const { return t0_; }
  [[nodiscard]] const LoopHealth& drive_health() const { return drive_loop_.health(); }
  [[nodiscard]] const LoopHealth& sensor_health() const { return acquire_loop_.health(); }
  /// Valid after join().
  [[nodiscard]] StopCause cause() const { return cause_; }
  [[nodiscard]] const OutputOutcome& outcome() const { return drive_loop_.outcome(); }
  /// What the real-time set-up did or could not do; complete after join().
  [[nodiscard]] std::vector<std::string> realtime_notes() const;

 private:
  /// One of `program` and `waveform` is given.
  LoopRunner(const LoopRunnerSettings& settings, DriveProgram* program,
             const model::Excitation* waveform, LoopDevices devices, const RemoteControl* remote,
             PositionFeed* feed);
  void set_up_thread(int priority, std::string& note) const;

  LoopRunnerSettings settings_;
  LoopDevices devices_;
  const RemoteControl* remote_;  ///< may be null
  std::optional<CpuLatencyRequest> cpu_latency_;
  std::string memory_note_, cpu_note_, drive_note_, acquire_note_;
  std::atomic<bool> stop_{false}, consumer_failed_{false};
  std::atomic<bool> drive_done_{false}, acquire_done_{false};
  SpscRing<DriveSample> drive_ring_;
  SpscRing<SensorSample> sensor_ring_;
  SensorHealth sensor_health_;
  SafetySupervisor supervisor_;
  std::optional<WaveformProgram> waveform_program_;
  DriveLoop drive_loop_;
  AcquireLoop acquire_loop_;
  hal::TimeNs t0_ = 0;
  StopCause cause_ = StopCause::none;
  std::latch threads_ready_{2}, time_origin_fixed_{1};
  std::thread drive_thread_, acquire_thread_;
  bool clock_hooked_ = false;
};

}  // namespace piezo::firmware
