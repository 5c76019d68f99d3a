#include "run_session.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <thread>

#include "piezo/firmware/loop_runner.hpp"
#include "sample_collector.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::host {
namespace {

using namespace std::chrono_literals;
using firmware::DriveSample;
using firmware::SensorSample;

constexpr auto kDrainPeriod = 5ms;
constexpr auto kStatusPeriod = 200ms;
LoopSummary summarise(const firmware::LoopHealth& h) {
  LoopSummary s;
  s.samples = h.cycles.load();
  s.overruns = h.overruns.load();
  s.missed_cycles = h.missed_cycles.load();
  s.dropped = h.dropped_samples.load();
  s.errors = h.errors.load();
  s.p50_us = h.period_error.quantile_us(0.5);
  s.p99_us = h.period_error.quantile_us(0.99);
  s.max_us = h.period_error.max_us();
  s.mean_us = h.period_error.mean_us();
  const auto& bins = h.period_error.bins();
  // Trailing empty bins carry nothing: cut them.
  std::size_t used = bins.size();
  while (used > 0 && bins[used - 1] == 0) --used;
  s.histogram.assign(bins.begin(), bins.begin() + static_cast<std::ptrdiff_t>(used));
  return s;
}

}  // namespace

std::string RunSummary::stop_cause() const {
  return host_error.empty() ? std::string(firmware::to_string(cause)) : "log_failed";
}

std::string RunSummary::output_state() const {
  if (!output.zero_confirmed) return "output_unconfirmed";
  if (output.enable_status != hal::Status::ok) return "enable_unconfirmed";
  return "confirmed";
}

std::string RunSummary::status() const {
  if (!host_error.empty()) return "failed";
  switch (cause) {
    case firmware::StopCause::completed:
      return "completed";
    case firmware::StopCause::interrupted:
      return "interrupted";
    default:
      return "failed";
  }
}

RunSummary execute_run(const RunConfig& c, Rig& rig, RunLog& log, const std::atomic<bool>& stop,
                       const std::function<void(const LiveStatus&)>& on_status) {
  hal::Clock& clock = *rig.clock;
  RunSummary summary;
  const model::Sawtooth waveform(c.model.drive.V0, c.model.drive.f, c.model.drive.D());
  firmware::LoopRunner runner(
      {{c.drive.rate_hz, c.run.duration_s, 1.0 / c.model.drive.f, c.drive.limits},
       c.safety,
       c.sensor.rate_hz(),
       !c.virtual_clock(),
       c.run.priority,
       c.run.lock_memory},
      waveform, {clock, *rig.drive, *rig.sensor, *rig.lines});
  runner.start([&](hal::TimeNs t0) { rig.start_at(t0); });

  std::optional<ObserverStage> observer;
  if (c.observer.enabled) {
    observer.emplace(c.model.motor, c.observer.gains, 1.0 / c.drive.rate_hz,
                     rig.drive->output_latency_s());
  }
  SampleCollector collector(rig.t0, c.sensor.r2_m, observer ? &*observer : nullptr);
  bool log_ok = true;
  auto append_log = [&] {
    if (!log_ok) return;
    try {
      log.append(collector.buffer());
    } catch (const std::exception& e) {
      // Stop the drive as on a stop request; the run ends failed.
      log_ok = false;
      summary.host_error = e.what();
      runner.consumer_failed();
    }
  };
  auto drain = [&] {
    runner.drain([&](const DriveSample& s) { collector.add(s); },
                 [&](const SensorSample& s) { collector.add(s); });
  };
  auto last_flush = std::chrono::steady_clock::now();
  auto last_status = last_flush;
  const auto flush_interval = std::chrono::duration<double>(c.run.flush_interval_s);
  auto host_loop = [&] {
    while (!runner.finished()) {
      std::this_thread::sleep_for(kDrainPeriod);
      if (stop.load()) runner.request_stop();
      drain();
      const auto now = std::chrono::steady_clock::now();
      if (now - last_flush >= flush_interval) {
        append_log();
        last_flush = now;
      }
      if (on_status && now - last_status >= kStatusPeriod) {
        on_status({hal::to_seconds(clock.now() - rig.t0), c.run.duration_s, collector.last_V(),
                   collector.last_theta(), observer ? observer->summary().last_residual_rad : 0.0,
                   runner.sensor_health().cycles.load(), runner.sensor_health().errors.load(),
                   runner.drive_health().overruns.load()});
        last_status = now;
      }
    }
  };
  try {
    host_loop();
  } catch (const std::exception& e) {
    // Whatever failed on the host side, the drive stops safely first.
    summary.host_error = e.what();
    runner.consumer_failed();
  }
  runner.join();
  drain();
  if (observer) observer->finish(collector.buffer());
  append_log();
  summary.cause = runner.cause();
  summary.output = runner.outcome();

  summary.drive = summarise(runner.drive_health());
  summary.sensor = summarise(runner.sensor_health());
  summary.drive.errors_by_class = collector.drive_errors();
  summary.sensor.errors_by_class = collector.sensor_errors();
  if (observer) summary.observer = observer->summary();
  summary.theta_end_rad = collector.last_theta();
  summary.t_end_s = collector.last_good_t();
  summary.mean_velocity_rad_s =
      summary.t_end_s > 0.0 ? summary.theta_end_rad / summary.t_end_s : 0.0;
  summary.realtime_notes = runner.realtime_notes();
  return summary;
}

}  // namespace piezo::host
