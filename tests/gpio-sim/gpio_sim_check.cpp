// Runs inside a qemu guest with a gpio-sim bank of 16 lines: the project's
// real gpiod backend drives the kernel's simulated GPIO chip, and every
// output is read back from sysfs while the backend still holds its lines.
// Usage: gpio_sim_check CHIP SYSFS_DIR   (e.g. gpiochip0
// /sys/devices/platform/gpio-sim.0/gpiochip0) Prints one PASS or FAIL line per check; the exit code
// is the number of failures.
//
// Wiring in the bank: DAC data D0..D7 on lines 0..7, /WR on 8, amplifier
// enable on 10, sync on 11, e-stop (active low, pulled up) on 12.

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "piezo/firmware/loop_runner.hpp"
#include "piezo/hal/gpio/gpio_digital_lines.hpp"
#include "piezo/hal/gpio/parallel_dac.hpp"
#include "piezo/hal/gpiod/gpiod_lines.hpp"
#include "piezo/hal/gpiod/gpiod_rig.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/null_drive.hpp"
#include "piezo/hal/sim/null_sensor.hpp"

namespace {

using namespace piezo;

std::string g_sysfs;
int g_failures = 0;

void check(bool ok, const std::string& what) {
  fmt::print("{} {}\n", ok ? "PASS" : "FAIL", what);
  std::fflush(stdout);
  if (!ok) ++g_failures;
}

int read_line(unsigned offset) {
  std::ifstream in(fmt::format("{}/sim_gpio{}/value", g_sysfs, offset));
  int v = -1;
  in >> v;
  return v;
}

void set_pull(unsigned offset, const char* pull) {
  std::ofstream(fmt::format("{}/sim_gpio{}/pull", g_sysfs, offset)) << pull;
}

/// The run's loops as piezod starts them, on a null drive and sensor: only
/// the lines are real here. Real-time set-up is off: the guest is emulated.
firmware::LoopRunnerSettings loop_settings(double rate_hz, double duration_s) {
  firmware::LoopRunnerSettings s;
  s.drive = {rate_hz, duration_s};
  s.sensor_rate_hz = 100.0;
  s.realtime = false;
  return s;
}

/// The one axis of these runs, following `program`.
std::vector<firmware::RunAxis> one_axis(hal::Drive& drive, hal::DisplacementSensor& sensor,
                                        firmware::DriveProgram& program, double period_s) {
  return {{drive, sensor, program, {0.0, 80.0, 1e6}, period_s, firmware::SafetySettings{}}};
}

/// Forwards to the real lines and reads every line back from sysfs after
/// each bulk write: the sequence the DAC saw.
class ReadBack final : public hal::OutputLineGroup {
 public:
  ReadBack(hal::OutputLineGroup& real, std::vector<unsigned> offsets)
      : real_(real), offsets_(std::move(offsets)) {}
  hal::Status set_levels(std::span<const int> levels) override {
    const hal::Status s = real_.set_levels(levels);
    std::vector<int> seen;
    for (unsigned o : offsets_) seen.push_back(read_line(o));
    steps.push_back(seen);
    return s;
  }
  [[nodiscard]] std::size_t size() const override { return real_.size(); }
  std::vector<std::vector<int>> steps;

 private:
  hal::OutputLineGroup& real_;
  std::vector<unsigned> offsets_;
};

void check_dac(const std::string& chip, bool data_active_low) {
  const std::vector<unsigned> offsets{0, 1, 2, 3, 4, 5, 6, 7, 8};
  const hal::gpio::ParallelDacSettings settings{.bits = 8,
                                                .has_strobe = true,
                                                .data_active_low = data_active_low,
                                                .strobe_active_low = true,
                                                .full_scale_V = 5.0,
                                                .amplifier_gain = 20.0};
  hal::gpiod::GpiodOutputs lines(chip, offsets, hal::gpio::ParallelDac::idle_levels(settings),
                                 "gpio-sim-check");
  // Before any write: the kernel holds the requested levels, code 0 (0 V)
  // and /WR idle, not full scale.
  bool at_zero = read_line(8) == 1;
  for (unsigned bit = 0; bit < 8; ++bit)
    at_zero = at_zero && read_line(bit) == (data_active_low ? 1 : 0);
  check(at_zero, fmt::format("DAC{} right after the request: code 0 on D0..D7, /WR idle high",
                             data_active_low ? " (data active low)" : ""));
  ReadBack readback(lines, offsets);
  hal::gpio::ParallelDac dac(settings, readback);
  // Codes whose bit patterns are not palindromes, so a reversed bit order shows.
  for (const unsigned code : {0u, 1u, 0x80u, 0x12u, 0xC5u, 0xFFu}) {
    readback.steps.clear();
    const double volts = 100.0 * code / 255.0;
    const bool written = dac.write(volts) == hal::Status::ok && dac.code_for(volts) == code;
    std::vector<int> data;
    for (unsigned bit = 0; bit < 8; ++bit) {
      const int logical = static_cast<int>((code >> bit) & 1u);
      data.push_back(data_active_low ? 1 - logical : logical);
    }
    bool ok = written && readback.steps.size() == 3;
    const int strobe_expected[3] = {1, 0, 1};  // /WR idle high, pulse low, back high
    for (std::size_t s = 0; ok && s < 3; ++s) {
      ok = std::equal(data.begin(), data.end(), readback.steps[s].begin()) &&
           readback.steps[s][8] == strobe_expected[s];
    }
    check(ok,
          fmt::format("DAC{} code 0x{:02X}: D0..D7 on lines 0..7 (LSB first), /WR high-low-high",
                      data_active_low ? " (data active low)" : "", code));
  }
}

void check_enable_and_sync(const std::string& chip, bool enable_active_low) {
  const hal::gpio::GpioLinesSettings settings{.has_sync = true,
                                              .enable_active_low = enable_active_low};
  hal::gpiod::GpiodOutputs outputs(
      chip, {10, 11}, hal::gpio::GpioDigitalLines::idle_levels(settings), "gpio-sim-check");
  const int on = enable_active_low ? 0 : 1;
  check(read_line(10) == 1 - on && read_line(11) == 0,
        fmt::format("enable (active {}) and sync inactive right after the request",
                    enable_active_low ? "low" : "high"));
  hal::gpio::GpioDigitalLines lines(settings, outputs, nullptr);
  (void)lines.set_amplifier_enable(true);
  check(read_line(10) == on, fmt::format("enable asserted reads {} (active {})", on,
                                         enable_active_low ? "low" : "high"));
  (void)lines.set_amplifier_enable(false);
  check(read_line(10) == 1 - on, "enable released");
  (void)lines.set_sync(true);
  const int sync_high = read_line(11);
  (void)lines.set_sync(false);
  check(sync_high == 1 && read_line(11) == 0, "sync pulses high, then low");
}

// The devices as the config builds them (hal::gpiod's own line requests).
void check_rig_devices(const std::string& chip) {
  set_pull(12, "pull-up");
  hal::gpiod::GpiodDacSettings dac_settings{
      .chip = chip, .data_offsets = {0, 1, 2, 3, 4, 5, 6, 7}, .strobe_offset = 8, .dac = {}};
  dac_settings.dac = {.bits = 8,
                      .has_strobe = true,
                      .data_active_low = false,
                      .strobe_active_low = true,
                      .full_scale_V = 5.0,
                      .amplifier_gain = 20.0};
  hal::gpiod::GpiodParallelDac dac(dac_settings, "gpio-sim-check");
  const bool written = dac.write(100.0 * 0xC5 / 255.0) == hal::Status::ok;
  bool ok = written && read_line(8) == 1;
  for (unsigned bit = 0; bit < 8; ++bit)
    ok = ok && read_line(bit) == static_cast<int>((0xC5u >> bit) & 1u);
  check(ok, "GpiodParallelDac (as built from a config) latches code 0xC5 on lines 0..7");

  hal::gpiod::GpiodLinesSettings line_settings{.chip = chip,
                                               .enable_offset = 10,
                                               .sync_offset = 11,
                                               .estop_offset = 12,
                                               .trigger_offsets = {},
                                               .gpio = {},
                                               .triggers = {}};
  const auto lines = hal::gpiod::open_rig_lines(line_settings, "gpio-sim-check");
  const bool idle = read_line(10) == 0;
  (void)lines->set_amplifier_enable(true);
  const bool enabled = read_line(10) == 1;
  (void)lines->set_amplifier_enable(false);
  check(idle && enabled && read_line(10) == 0,
        "the rig's lines (as built from a config): enable requested off, asserted, released");

  // What piezod's reset_fault reaches: refused while the button is held,
  // and after the release the latch clears (the enable stays off until then).
  set_pull(12, "pull-down");
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const bool refused = !lines->reset_estop();
  set_pull(12, "pull-up");
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  (void)lines->set_amplifier_enable(true);
  const bool latched = read_line(10) == 0;
  const bool reset = lines->reset_estop();
  (void)lines->set_amplifier_enable(true);
  const bool enabled_again = read_line(10) == 1;
  (void)lines->set_amplifier_enable(false);
  check(refused && latched && reset && enabled_again,
        fmt::format("the rig's lines (as built from a config): a press latches, its reset is "
                    "refused while held ({}), the enable stays off once released ({}), the reset "
                    "clears it ({}, enable {})",
                    refused, latched, reset, enabled_again));
}

// A start refused because the e-stop is pressed: the amplifier (enable
// active low here) must never be enabled, not even for one write.
void check_refused_start(const std::string& chip) {
  set_pull(12, "pull-down");  // pressed before the run
  const hal::gpio::GpioLinesSettings settings{
      .has_sync = true, .enable_active_low = true, .estop_active_low = true};
  hal::gpiod::GpiodOutputs real(chip, {10, 11}, hal::gpio::GpioDigitalLines::idle_levels(settings),
                                "gpio-sim-check");
  ReadBack outputs(real, {10, 11});
  hal::gpiod::GpiodEdgeInput estop(chip, 12, "gpio-sim-check");
  hal::gpio::GpioDigitalLines lines(settings, outputs, &estop);
  hal::posix::MonotonicClock clock;
  hal::sim::NullDrive drive(clock);
  hal::sim::NullSensor sensor(clock);
  const model::Sawtooth saw(80.0, 50.0, 0.75);
  firmware::WaveformProgram program(saw);
  firmware::LoopRunner runner(loop_settings(1000.0, 1.0), one_axis(drive, sensor, program, 0.02),
                              clock, lines);
  (void)runner.start({});
  runner.join();
  const firmware::StopCause cause = runner.cause();
  bool ever_enabled = false;
  for (const auto& step : outputs.steps) ever_enabled = ever_enabled || step[0] == 0;
  check(cause == firmware::StopCause::estop && !runner.outcome().enabled_ever && !ever_enabled &&
            read_line(10) == 1,
        fmt::format("a start refused by a pressed e-stop never enables (enable line reads {}, "
                    "held; {} writes, none enabling)",
                    read_line(10), outputs.steps.size()));
  set_pull(12, "pull-up");
}

void check_loop_sync_and_estop(const std::string& chip) {
  set_pull(12, "pull-up");  // e-stop released (normally closed contact, active low)
  const hal::gpio::GpioLinesSettings settings{.has_sync = true, .estop_active_low = true};
  hal::gpiod::GpiodOutputs outputs(
      chip, {10, 11}, hal::gpio::GpioDigitalLines::idle_levels(settings), "gpio-sim-check");
  hal::gpiod::GpiodEdgeInput estop(chip, 12, "gpio-sim-check");
  hal::gpio::GpioDigitalLines lines(settings, outputs, &estop);
  hal::posix::MonotonicClock clock;
  hal::sim::NullDrive drive(clock);
  hal::sim::NullSensor sensor(clock);
  constexpr double kRate = 1000.0, kWaveform = 50.0;
  const model::Sawtooth saw(80.0, kWaveform, 0.75);
  firmware::WaveformProgram program(saw);
  firmware::LoopRunner runner(loop_settings(kRate, 100.0),
                              one_axis(drive, sensor, program, 1.0 / kWaveform), clock, lines);
  (void)runner.start({});

  std::this_thread::sleep_until(std::chrono::steady_clock::now() + std::chrono::milliseconds(50));
  const bool enabled_while_running = read_line(10) == 1;
  // Sync pulses once per waveform period, seen by polling the line until
  // kPulses rising edges: a poller under emulation, on a loaded machine,
  // may miss a 1 ms pulse and take longer, but pulses can never come closer
  // together than a period (less one late cycle at each end). Bounded well
  // inside the rings' 2 s, which the e-stop check below drains.
  constexpr int kPulses = 5;
  const auto polled_until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1200);
  int rising = 0, last = read_line(11);
  std::chrono::steady_clock::time_point first_edge{}, last_edge{};
  while (rising < kPulses && std::chrono::steady_clock::now() < polled_until) {
    const int v = read_line(11);
    if (v == 1 && last == 0) {
      last_edge = std::chrono::steady_clock::now();
      if (rising++ == 0) first_edge = last_edge;
    }
    last = v;
  }
  const double span_s = std::chrono::duration<double>(last_edge - first_edge).count();
  check(enabled_while_running, "enable high while the drive loop runs");
  check(rising == kPulses && span_s > (kPulses - 2) / kWaveform,
        fmt::format("{} of {} sync pulses seen, the first to the last {:.1f} ms apart ({} "
                    "periods at {:g} Hz: {:.0f} ms)",
                    rising, kPulses, 1e3 * span_s, kPulses - 1, kWaveform,
                    1e3 * (kPulses - 1) / kWaveform));

  // Press: the e-stop line goes low. The supervisor must drop enable in the
  // first drive cycle after the edge (time-stamped by the kernel): no cycle
  // whose deadline follows the edge may still drive. Wall time is reported
  // too; under software emulation the guest's own wake-ups wander.
  set_pull(12, "pull-down");
  // The rings hold 2 s: the run is drained once it has stopped.
  runner.join();
  const hal::TimeNs edge = estop.last_edge_ns();
  firmware::DriveSample last_sample{};
  int driving_after_edge = 0;
  runner.drain(
      0,
      [&](const firmware::DriveSample& s) {
        if (s.phase == firmware::DrivePhase::driving && s.t > edge) ++driving_after_edge;
        last_sample = s;
      },
      [](const firmware::SensorSample&) {});
  check(runner.cause() == firmware::StopCause::estop,
        "the e-stop edge reached the safety supervisor");
  check(read_line(10) == 0, "enable low after the e-stop (read while the lines are held)");
  check(edge > 0 && driving_after_edge == 0 && last_sample.phase == firmware::DrivePhase::stopped,
        fmt::format("enable dropped in the first drive cycle after the edge ({} cycles drove past "
                    "it; {:.3f} ms after it in wall time, drive period {:.1f} ms)",
                    driving_after_edge, 1e3 * hal::to_seconds(last_sample.t - edge), 1e3 / kRate));

  // The press latches on the board (piezod's reset_fault clears it): while
  // the button is held a reset is refused; released, the enable stays down
  // whatever is asked until the reset; after it the next run enables.
  const bool refused_while_held = !lines.reset_estop();
  set_pull(12, "pull-up");
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  (void)lines.set_amplifier_enable(true);
  const bool latched_after_release = read_line(10) == 0;
  const bool reset = lines.reset_estop();
  (void)lines.set_amplifier_enable(true);
  const bool enabled_after_reset = read_line(10) == 1;
  (void)lines.set_amplifier_enable(false);
  check(refused_while_held && latched_after_release && reset && enabled_after_reset &&
            read_line(10) == 0,
        fmt::format("the press latched: reset refused while held ({}), enable low after the "
                    "release ({}), reset once released ({}), enable high at the next run ({})",
                    refused_while_held, latched_after_release, reset, enabled_after_reset));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    fmt::print(stderr, "usage: gpio_sim_check CHIP SYSFS_DIR\n");
    return 100;
  }
  const std::string chip = argv[1];
  g_sysfs = argv[2];
  try {
    check_dac(chip, false);
    check_dac(chip, true);
    check_enable_and_sync(chip, false);
    check_enable_and_sync(chip, true);
    check_rig_devices(chip);
    check_refused_start(chip);
    check_loop_sync_and_estop(chip);
  } catch (const std::exception& e) {
    check(false, std::string("exception: ") + e.what());
  }
  fmt::print("gpio-sim checks done: {} failed\n", g_failures);
  return g_failures;
}
