#pragma once
/// @file
/// The rig's digital lines on GPIO: amplifier enable, sync and the axes'
/// trigger lines as one output group, e-stop as an input with edge events,
/// each line's polarity from config.
///
/// The e-stop has a path of its own: a watcher thread blocks on the input's
/// edge events and drops the enable line itself, however long the drive
/// loop is blocked in a drive write. Once tripped, the enable stays off,
/// whatever the loop asks, until the button is released and reset_estop()
/// clears the latch (piezod's reset_fault). The protocol's e-stop drops it
/// the same way (trip()), until the next run enables it.

#include <atomic>
#include <thread>
#include <vector>

#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/line_group.hpp"

namespace piezo::hal::gpio {

struct GpioLinesSettings {
  bool has_sync = true;
  bool enable_active_low = false;
  bool sync_active_low = false;
  bool estop_active_low = true;  ///< a normally-closed e-stop pulled up: pressed = low
};

/// The axes' trigger lines among the outputs.
struct GpioTriggerLines {
  /// The board's axes that have a trigger line, in the order their lines
  /// follow enable and sync in the output group.
  std::vector<std::size_t> axes;
  bool active_low = false;
};

class GpioDigitalLines final : public DigitalLines {
 public:
  /// The physical levels of the outputs (enable, sync if any, then the
  /// triggers) all inactive: what the lines must be requested at.
  [[nodiscard]] static std::vector<int> idle_levels(const GpioLinesSettings& settings,
                                                    const GpioTriggerLines& triggers = {});

  /// `outputs`: enable, sync if any, then the triggers, requested at idle_levels().
  /// `estop` may be null (no e-stop wired); when given, its watcher starts
  /// here and reads the line once before returning.
  GpioDigitalLines(const GpioLinesSettings& settings, OutputLineGroup& outputs, InputLine* estop,
                   GpioTriggerLines triggers = {});
  ~GpioDigitalLines() override;
  GpioDigitalLines(const GpioDigitalLines&) = delete;
  GpioDigitalLines& operator=(const GpioDigitalLines&) = delete;

  Status set_amplifier_enable(bool enabled) override;
  Status set_sync(bool high) override;
  /// The level now, and whether the watcher has tripped since the start.
  [[nodiscard]] EstopState poll_estop() override;
  bool trip() override;
  [[nodiscard]] bool has_trigger(std::size_t axis) const override;
  Status set_trigger(std::size_t axis, bool high) override;
  /// Reads the button: released, clears the latch and the edges seen.
  [[nodiscard]] bool reset_estop() override;

 private:
  Status apply();
  /// Reads the input; trips on a press, an edge or a failing line.
  void check_estop();
  void trip_on_estop();
  void write_off();
  void watch();
  [[nodiscard]] bool pressed(int level) const { return (level == 0) == settings_.estop_active_low; }

  GpioLinesSettings settings_;
  GpioTriggerLines trigger_lines_;
  OutputLineGroup& outputs_;
  InputLine* estop_;
  bool enabled_ = false;
  bool sync_ = false;
  std::vector<bool> triggers_;               ///< asserted, per entry of trigger_axes
  std::vector<int> levels_;                  ///< the group's, sized once
  std::vector<int> off_;                     ///< the group's with every output inactive
  std::atomic<bool> tripped_{false};         ///< by the e-stop input: until reset_estop()
  std::atomic<bool> remote_tripped_{false};  ///< by trip(): until the next enable
  std::atomic<bool> trip_write_failed_{false};
  std::atomic<bool> stopping_{false};
  std::thread watcher_;
};

}  // namespace piezo::hal::gpio
