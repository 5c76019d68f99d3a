#include "piezo/firmware/loop_runner.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::firmware {
namespace {

// From the time origin's fixing to the first deadline: the loop threads are
// set up and waiting by then, so this only covers their wake-up.
constexpr double kStartLead_s = 0.02;

std::size_t ring_capacity(double rate_hz, double seconds) {
  return static_cast<std::size_t>(std::max(4096.0, rate_hz * seconds));
}

}  // namespace

LoopRunner::LoopRunner(const LoopRunnerSettings& settings, const model::Excitation& waveform,
                       LoopDevices devices, const RemoteControl* remote, PositionFeed* feed)
    : LoopRunner(settings, nullptr, &waveform, devices, remote, feed) {}

LoopRunner::LoopRunner(const LoopRunnerSettings& settings, DriveProgram& program,
                       LoopDevices devices, const RemoteControl* remote, PositionFeed* feed)
    : LoopRunner(settings, &program, nullptr, devices, remote, feed) {}

LoopRunner::LoopRunner(const LoopRunnerSettings& settings, DriveProgram* program,
                       const model::Excitation* waveform, LoopDevices devices,
                       const RemoteControl* remote, PositionFeed* feed)
    : settings_(settings),
      devices_(devices),
      remote_(remote),
      drive_ring_(ring_capacity(settings.drive.rate_hz, settings.ring_s)),
      sensor_ring_(ring_capacity(settings.sensor_rate_hz, settings.ring_s)),
      supervisor_(settings.safety, sensor_health_, devices.clock.now()),
      waveform_program_(waveform != nullptr
                            ? std::optional<WaveformProgram>(std::in_place, *waveform)
                            : std::nullopt),
      drive_loop_(settings.drive, program != nullptr ? *program : *waveform_program_, supervisor_,
                  {devices.clock, devices.drive, devices.lines, drive_ring_, stop_}),
      acquire_loop_(devices.clock, devices.sensor, settings.sensor_rate_hz, sensor_health_,
                    sensor_ring_, feed) {
  supervisor_.set_remote(remote);
  const bool travel_window = std::isfinite(settings.safety.travel_min_rad) ||
                             std::isfinite(settings.safety.travel_max_rad);
  if (travel_window && feed != nullptr) {
    supervisor_.set_travel_feed(feed, settings.zero_m, settings.r2_m);
  }
}

LoopRunner::~LoopRunner() {
  request_stop();
  consumer_failed_.store(true);  // nobody drains any more: time must not wait
  join();
}

void LoopRunner::set_up_thread(int priority, std::string& note) const {
  if (!settings_.realtime) return;
  prefault_stack();
  note = priority > 0 ? make_thread_fifo(priority).note : "normal priority (priority = 0)";
}

hal::TimeNs LoopRunner::start(const std::function<void(hal::TimeNs)>& on_time_origin,
                              std::function<bool()> lagging) {
  hal::Clock& clock = devices_.clock;
  if (settings_.realtime) {
    if (settings_.lock_memory) memory_note_ = lock_process_memory().note;
    cpu_note_ = cpu_latency_.emplace().result().note;
  }
  clock.set_backpressure([this, lagging = std::move(lagging)] {
    // A stop or an e-stop is never held back: the loop must see it.
    const bool estop = remote_ != nullptr && remote_->estop.load();
    if (consumer_failed_.load() || stop_.load() || estop) return false;
    return drive_ring_.size_approx() > drive_ring_.capacity() / 2 ||
           sensor_ring_.size_approx() > sensor_ring_.capacity() / 2 || (lagging && lagging());
  });
  clock_hooked_ = true;

  hal::SleeperScope drive_scope(clock), acquire_scope(clock);
  drive_thread_ = std::thread([&, scope = std::move(drive_scope)]() mutable {
    const hal::SleeperScope mine(std::move(scope));
    set_up_thread(settings_.priority, drive_note_);
    threads_ready_.count_down();
    time_origin_fixed_.wait();
    cause_ = drive_loop_.run(t0_);
    drive_done_.store(true, std::memory_order_release);
  });
  acquire_thread_ = std::thread([&, scope = std::move(acquire_scope)]() mutable {
    const hal::SleeperScope mine(std::move(scope));
    set_up_thread(std::max(0, settings_.priority - 1), acquire_note_);
    threads_ready_.count_down();
    time_origin_fixed_.wait();
    acquire_loop_.run(t0_, drive_done_);
    acquire_done_.store(true, std::memory_order_release);
  });
  threads_ready_.wait();
  t0_ = clock.now() + hal::from_seconds(kStartLead_s);
  supervisor_.set_time_origin(t0_);
  supervisor_.set_end(t0_ + hal::from_seconds(settings_.drive.duration_s));
  if (on_time_origin) on_time_origin(t0_);
  time_origin_fixed_.count_down();
  return t0_;
}

void LoopRunner::join() {
  if (drive_thread_.joinable()) drive_thread_.join();
  if (acquire_thread_.joinable()) acquire_thread_.join();
  if (clock_hooked_) {
    devices_.clock.set_backpressure({});
    clock_hooked_ = false;
  }
  cpu_latency_.reset();
}

std::vector<std::string> LoopRunner::realtime_notes() const {
  if (!settings_.realtime) return {"virtual clock: no real-time set-up"};
  std::vector<std::string> notes;
  if (settings_.lock_memory) notes.push_back(memory_note_);
  notes.push_back(cpu_note_);
  notes.push_back("drive loop: " + drive_note_);
  notes.push_back("acquire loop: " + acquire_note_);
  return notes;
}

}  // namespace piezo::firmware
