#pragma once
// The run under way, or the last one: its request, the loop runner with
// the program it follows, and what the network thread tracks beside it.
// Internal to the daemon's sources.

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>

#include "daemon.hpp"
#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/loop_runner.hpp"
#include "piezo/firmware/run_guard.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::daemon {

struct Daemon::Run {
  /// One axis of the run: the readings it follows, its move, and what the
  /// board learns of it at the end. A run drives one axis, a group move
  /// several (each ends on its own).
  struct Part {
    explicit Part(ServedAxis& a) : axis(a) {}
    ServedAxis& axis;
    firmware::PositionFeed feed;                     ///< the acquire loop's readings, for a move
    std::unique_ptr<firmware::MoveController> move;  ///< a closed-loop move's program, if it is one
    std::unique_ptr<firmware::ScanController> scan;  ///< a scan's program, if it is one
    protocol::ScanAccount scan_taken;                ///< the scan as the board took it
    std::vector<protocol::TriggerPulse> pulses;      ///< a scan's, as fired
    std::optional<double> model_velocity_rad_per_s;  ///< the model's beside the span's
    bool move_takes_its_zero = false;                ///< the axis had no zero when it began
    /// Measured after the run, at 0 V: the position a finished move reports
    /// (the controller's last reading came before the stop's ramp).
    std::optional<double> final_displacement_m;
    firmware::DrivePhase phase = firmware::DrivePhase::driving;  ///< its latest drive record's
  };

  std::uint64_t id = 0;
  protocol::ConfigureRequest request;
  model::Sawtooth waveform;
  firmware::WaveformProgram waveform_program{waveform};  ///< a plain run's program
  firmware::RemoteControl remote;
  std::unique_ptr<firmware::LoopRunner> runner;
  hal::TimeNs t0 = 0;
  double lease_s = 0.0;  // set at the start
  bool finished = false;
  protocol::RunSummary summary;  ///< once finished
  /// At least one, in the order the run's loops drive them.
  std::vector<std::unique_ptr<Part>> parts;
  std::unique_ptr<firmware::CalibrationProgram> calibration;  ///< the calibration's, if it is one
  std::unique_ptr<firmware::RunGuard> guard;  ///< a plain run's, with [safety] protect_runs
  // The virtual clock's lease runs on wall time, checked by the network thread.
  std::atomic<std::int64_t> lease_renewed_ns{0};
  std::atomic<std::uint64_t> drive_acked{0}, drive_recorded{0};

  Run(const protocol::ConfigureRequest& r, const std::vector<ServedAxis*>& axes)
      : request(r), waveform(r.drive.V0, r.drive.f, r.drive.rise()) {
    for (ServedAxis* a : axes) parts.push_back(std::make_unique<Part>(*a));
  }
  /// The run's first (a run of one axis: its only) part.
  [[nodiscard]] Part& first() { return *parts.front(); }
  [[nodiscard]] const Part& first() const { return *parts.front(); }
  [[nodiscard]] bool is_move() const { return parts.front()->move != nullptr; }
  [[nodiscard]] bool is_scan() const { return parts.front()->scan != nullptr; }
  /// The part of the board's axis `index`, or null.
  [[nodiscard]] Part* part_of(std::size_t index) {
    for (const auto& p : parts)
      if (p->axis.index == index) return p.get();
    return nullptr;
  }
};

/// A refusal of a value beyond the board's limits, naming its key.
inline protocol::ProtocolError out_of_limits(std::string_view key, const std::string& message) {
  return {protocol::code::out_of_limits, key, std::string(key) + ": " + message};
}

}  // namespace piezo::daemon
