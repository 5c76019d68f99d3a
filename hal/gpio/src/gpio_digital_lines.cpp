#include "piezo/hal/gpio/gpio_digital_lines.hpp"

#include <chrono>
#include <stdexcept>
#include <utility>

namespace piezo::hal::gpio {
namespace {

// How often the watcher re-reads the level when no edge comes: a pressed
// e-stop whose edge was lost still trips within this time.
constexpr std::int64_t kWatchPeriodNs = 20'000'000;

int level_of(bool asserted, bool active_low) {
  return asserted != active_low ? 1 : 0;
}

}  // namespace

std::vector<int> GpioDigitalLines::idle_levels(const GpioLinesSettings& s,
                                               const GpioTriggerLines& triggers) {
  std::vector<int> levels{level_of(false, s.enable_active_low)};
  if (s.has_sync) levels.push_back(level_of(false, s.sync_active_low));
  for (std::size_t i = 0; i < triggers.axes.size(); ++i) {
    levels.push_back(level_of(false, triggers.active_low));
  }
  return levels;
}

GpioDigitalLines::GpioDigitalLines(const GpioLinesSettings& settings, OutputLineGroup& outputs,
                                   InputLine* estop, GpioTriggerLines triggers)
    : settings_(settings),
      trigger_lines_(std::move(triggers)),
      outputs_(outputs),
      estop_(estop),
      triggers_(trigger_lines_.axes.size(), false),
      levels_(idle_levels(settings, trigger_lines_)),
      off_(idle_levels(settings, trigger_lines_)) {
  if (outputs.size() != levels_.size()) {
    throw std::invalid_argument(
        "digital lines: expected enable, sync if configured, and the trigger lines");
  }
  if (estop_ != nullptr) {
    check_estop();  // a press held at start is seen before anything is enabled
    watcher_ = std::thread([this] { watch(); });
  }
}

GpioDigitalLines::~GpioDigitalLines() {
  stopping_.store(true);
  if (watcher_.joinable()) watcher_.join();
}

Status GpioDigitalLines::apply() {
  const bool enable = enabled_ && !tripped_.load() && !remote_tripped_.load();
  std::size_t i = 0;
  levels_[i++] = level_of(enable, settings_.enable_active_low);
  if (settings_.has_sync) levels_[i++] = level_of(sync_, settings_.sync_active_low);
  for (const bool trigger : triggers_) levels_[i++] = level_of(trigger, trigger_lines_.active_low);
  const Status s = outputs_.set_levels(std::span<const int>(levels_.data(), levels_.size()));
  // The watcher may have tripped between the check and the write: it wrote
  // enable off before or after ours; writing again settles it off.
  if (enable && (tripped_.load() || remote_tripped_.load())) return apply();
  return s;
}

Status GpioDigitalLines::set_amplifier_enable(bool enabled) {
  if (enabled) remote_tripped_.store(false);  // a new run's start
  enabled_ = enabled;
  return apply();
}

Status GpioDigitalLines::set_sync(bool high) {
  if (!settings_.has_sync) return Status::ok;
  sync_ = high;
  return apply();
}

bool GpioDigitalLines::has_trigger(std::size_t axis) const {
  for (const std::size_t a : trigger_lines_.axes)
    if (a == axis) return true;
  return false;
}

Status GpioDigitalLines::set_trigger(std::size_t axis, bool high) {
  for (std::size_t i = 0; i < trigger_lines_.axes.size(); ++i) {
    if (trigger_lines_.axes[i] != axis) continue;
    triggers_[i] = high;
    return apply();
  }
  return Status::io_error;
}

void GpioDigitalLines::trip_on_estop() {
  if (tripped_.exchange(true)) return;
  write_off();
}

bool GpioDigitalLines::trip() {
  remote_tripped_.store(true);
  write_off();
  return true;
}

bool GpioDigitalLines::reset_estop() {
  if (estop_ == nullptr) return true;
  // The edges of the press and of its release are drained first: an edge
  // after this read is a new press, and trips again.
  int edges = 0, level = 0;
  if (estop_->take_edges(edges) != Status::ok || estop_->level(level) != Status::ok) return false;
  if (pressed(level)) return false;
  tripped_.store(false);
  // A press between the read and the clear: the level says so, and trips again.
  check_estop();
  return !tripped_.load();
}

void GpioDigitalLines::write_off() {
  // Enable off, sync and triggers idle, written from the caller's thread:
  // the drive loop may be blocked in a drive write for a long time.
  if (outputs_.set_levels(std::span<const int>(off_.data(), off_.size())) != Status::ok) {
    trip_write_failed_.store(true);  // reported by every later poll
  }
}

void GpioDigitalLines::check_estop() {
  // A line that cannot be read counts as pressed: fail safe.
  (void)poll_estop();
}

void GpioDigitalLines::watch() {
  while (!stopping_.load()) {
    bool ready = false;
    const Status waited = estop_->wait_for_edge(kWatchPeriodNs, ready);
    if (waited != Status::ok) {
      trip_on_estop();
      std::this_thread::sleep_for(std::chrono::nanoseconds(kWatchPeriodNs));
      continue;
    }
    check_estop();
  }
}

EstopState GpioDigitalLines::poll_estop() {
  if (estop_ == nullptr) return {};
  // The loop looks too: whichever of the two sees the press first trips.
  EstopState state;
  int edges = 0, level = 0;
  state.status = estop_->take_edges(edges);
  if (state.status == Status::ok) state.status = estop_->level(level);
  state.pressed = state.status == Status::ok && pressed(level);
  if (state.status != Status::ok || edges > 0 || state.pressed) trip_on_estop();
  state.edge_seen = tripped_.load();
  if (trip_write_failed_.load()) state.status = Status::io_error;
  return state;
}

}  // namespace piezo::hal::gpio
