#include "piezo/firmware/loop_runner.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <fmt/format.h>

namespace piezo::firmware {
namespace {

// From the time origin's fixing to the first deadline: the loop threads are
// set up and waiting by then, so this only covers their wake-up.
constexpr double kStartLead_s = 0.02;

std::size_t ring_capacity(double rate_hz, double seconds) {
  return static_cast<std::size_t>(std::max(4096.0, rate_hz * seconds));
}

}  // namespace

LoopRunner::LoopRunner(const LoopRunnerSettings& settings, std::vector<RunAxis> axes,
                       hal::Clock& clock, hal::DigitalLines& lines, const RemoteControl* remote)
    : settings_(settings), clock_(clock), remote_(remote) {
  std::vector<DriveAxis> drive_axes;
  // Each sensor line's axes, in the board's order: a sensor of its own is a
  // line of its own.
  std::vector<std::pair<std::string, std::vector<AcquireAxis>>> lines_of_sensors;
  for (const RunAxis& axis : axes) {
    auto& parts = *axes_.emplace_back(std::make_unique<AxisParts>(
        ring_capacity(settings.drive.rate_hz, settings.ring_s),
        ring_capacity(settings.sensor_rate_hz, settings.ring_s), axis.safety, clock.now()));
    parts.supervisor.set_remote(remote);
    const bool travel_window =
        std::isfinite(axis.safety.travel_min_rad) || std::isfinite(axis.safety.travel_max_rad);
    if (travel_window && axis.feed != nullptr) {
      parts.supervisor.set_travel_feed(axis.feed, axis.zero_m, axis.r2_m, axis.heading);
    }
    drive_axes.push_back({axis.limits, axis.period_s, &axis.program, &parts.supervisor, &axis.drive,
                          &parts.drive_ring, axis.index, &parts.stop,
                          &parts.stop_now});
    const AcquireAxis reading{&axis.sensor, &parts.health, &parts.sensor_ring, axis.feed,
                              axis.index};
    const std::string line = axis.sensor.shared_line();
    const auto shared = std::find_if(lines_of_sensors.begin(), lines_of_sensors.end(),
                                     [&](const auto& l) { return !line.empty() && l.first == line; });
    if (shared != lines_of_sensors.end()) {
      shared->second.push_back(reading);
    } else {
      lines_of_sensors.push_back({line, {reading}});
    }
  }
  drive_loop_.emplace(settings.drive, std::move(drive_axes), DriveLoopIo{clock, lines, stop_, stop_now_});
  for (auto& [line, readings] : lines_of_sensors) {
    acquire_loops_.push_back(std::make_unique<AcquireLoop>(clock, std::move(readings),
                                                           settings.sensor_rate_hz, sensor_health_));
  }
  threads_ready_.emplace(static_cast<std::ptrdiff_t>(1 + acquire_loops_.size()));
  acquire_running_.store(acquire_loops_.size(), std::memory_order_release);
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

bool LoopRunner::rings_past_half() const {
  for (const auto& a : axes_) {
    if (a->drive_ring.size_approx() > a->drive_ring.capacity() / 2 ||
        a->sensor_ring.size_approx() > a->sensor_ring.capacity() / 2) {
      return true;
    }
  }
  return false;
}

hal::TimeNs LoopRunner::start(const std::function<void(hal::TimeNs)>& on_time_origin,
                              std::function<bool()> lagging) {
  hal::Clock& clock = clock_;
  if (settings_.realtime) {
    if (settings_.lock_memory) memory_note_ = lock_process_memory().note;
    cpu_note_ = cpu_latency_.emplace().result().note;
  }
  clock.set_backpressure([this, lagging = std::move(lagging)] {
    // A stop or an e-stop is never held back: the loop must see it.
    const bool estop = remote_ != nullptr && remote_->estop.load();
    if (consumer_failed_.load() || stop_.load() || estop) return false;
    return rings_past_half() || (lagging && lagging());
  });
  clock_hooked_ = true;

  hal::SleeperScope drive_scope(clock);
  drive_thread_ = std::thread([&, scope = std::move(drive_scope)]() mutable {
    const hal::SleeperScope mine(std::move(scope));
    set_up_thread(settings_.priority, drive_note_);
    threads_ready_->count_down();
    time_origin_fixed_.wait();
    cause_ = drive_loop_->run(t0_);
    drive_done_.store(true, std::memory_order_release);
  });
  for (std::size_t i = 0; i < acquire_loops_.size(); ++i) {
    hal::SleeperScope acquire_scope(clock);
    acquire_threads_.emplace_back([&, i, scope = std::move(acquire_scope)]() mutable {
      const hal::SleeperScope mine(std::move(scope));
      std::string note;
      set_up_thread(std::max(0, settings_.priority - 1), note);
      if (i == 0) acquire_note_ = std::move(note);  // every line's thread is set up alike
      threads_ready_->count_down();
      time_origin_fixed_.wait();
      acquire_loops_[i]->run(t0_, drive_done_);
      acquire_running_.fetch_sub(1, std::memory_order_acq_rel);
    });
  }
  threads_ready_->wait();
  t0_ = clock.now() + hal::from_seconds(kStartLead_s);
  for (const auto& a : axes_) {
    a->supervisor.set_time_origin(t0_);
    a->supervisor.set_end(t0_ + hal::from_seconds(settings_.drive.duration_s));
  }
  if (on_time_origin) on_time_origin(t0_);
  time_origin_fixed_.count_down();
  return t0_;
}

void LoopRunner::join() {
  if (drive_thread_.joinable()) drive_thread_.join();
  for (std::thread& t : acquire_threads_) {
    if (t.joinable()) t.join();
  }
  if (clock_hooked_) {
    clock_.set_backpressure({});
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
  notes.push_back(fmt::format("acquire loops, one per sensor line ({}): {}", acquire_loops_.size(),
                              acquire_note_));
  return notes;
}

}  // namespace piezo::firmware
