// Runs inside a qemu guest: the enable, sync and e-stop lines on a DAQ
// card's digital I/O, on Linux's comedi_parport driver over qemu's emulated
// parallel port (/dev/comedi0, configured here at I/O base 0x378), with the
// drive on comedi_test's clocked analog output (/dev/comedi1).
//
// comedi_parport: subdevice 0 the 8 data lines (DIO), 1 the status lines
// (DI: error, select, paper out, ack, busy), 2 the control lines (DO:
// strobe, auto-feed, init, select). qemu's port latches the data lines
// (read back as written) and derives its status lines from the control
// lines: init low sets busy, init and select high with strobe clears it.
// That is the operator's button here: the check writes the control lines,
// busy (status channel 4) is the e-stop input the backend reads. Every
// check reads the device side: the data register, the card's output.
// Prints one PASS or FAIL line per check; the exit code is the number of
// failures.

#include <comedilib.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>

#include "piezo/config/config_error.hpp"
#include "piezo/firmware/loop_runner.hpp"
#include "piezo/hal/comedi/comedi_analog_output.hpp"
#include "piezo/hal/comedi/comedi_digital_lines.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/null_sensor.hpp"
#include "piezo/model/waveform.hpp"

namespace {

using namespace piezo;
namespace comedi = hal::comedi;
using std::chrono::milliseconds;

constexpr const char* kPort = "/dev/comedi0";
constexpr const char* kCard = "/dev/comedi1";
constexpr unsigned kData = 0, kStatus = 1, kControl = 2;
constexpr unsigned kEnable = 0, kSync = 1, kBusy = 4;
// qemu's control bits: strobe 0x01, init 0x04, select 0x08.
constexpr unsigned kPressed = 0x0D, kReleased = 0x00;
constexpr double kGain = 20.0;

int g_failures = 0;

void check(bool ok, const std::string& what) {
  fmt::print("{} {}\n", ok ? "PASS" : "FAIL", what);
  std::fflush(stdout);
  if (!ok) ++g_failures;
}

/// Comedi's legacy attach, as comedi_config does: the parallel port at 0x378.
bool attach_parport() {
  const int fd = ::open(kPort, O_RDWR);
  if (fd < 0) return false;
  comedi_devconfig config{};
  std::strncpy(config.board_name, "comedi_parport", sizeof config.board_name - 1);
  config.options[0] = 0x378;
  const bool ok = ::ioctl(fd, COMEDI_DEVCONFIG, &config) == 0;
  ::close(fd);
  return ok;
}

/// The port as the test bench sees it: the data lines' levels and the
/// operator's button on the control lines.
class Bench {
 public:
  Bench() : port_(kPort) {}
  int data_line(unsigned channel) {
    unsigned bits = 0;
    if (comedi_dio_bitfield2(port_.get(), kData, 0, &bits, 0) < 0) return -1;
    return static_cast<int>((bits >> channel) & 1u);
  }
  int busy() {
    unsigned bit = 0;
    return comedi_dio_read(port_.get(), kStatus, kBusy, &bit) < 0 ? -1 : static_cast<int>(bit);
  }
  void button(bool pressed) {
    unsigned bits = pressed ? kPressed : kReleased;
    (void)comedi_dio_bitfield2(port_.get(), kControl, 0x0F, &bits, 0);
  }

 private:
  comedi::ComediDevice port_;
};

comedi::DigitalLinesSettings line_settings() {
  comedi::DigitalLinesSettings s;
  s.device = kPort;
  s.subdevice = -1;  // the port's first digital output or DIO: the data lines
  s.enable_channel = static_cast<int>(kEnable);
  s.sync_channel = static_cast<int>(kSync);
  s.estop_subdevice = static_cast<int>(kStatus);
  s.estop_channel = static_cast<int>(kBusy);
  s.lines.estop_active_low = true;  // busy low: pressed
  return s;
}

/// A config naming what the port does not have is refused naming the key.
void check_refused() {
  struct Case {
    const char* key;
    comedi::DigitalLinesSettings s;
  };
  Case cases[3] = {{"lines.comedi.estop_channel", line_settings()},
                   {"lines.comedi.subdevice", line_settings()},
                   {"lines.comedi.estop_subdevice", line_settings()}};
  cases[0].s.estop_channel = 9;                             // the status subdevice has 5
  cases[1].s.subdevice = static_cast<int>(kStatus);         // an input, not an output
  cases[2].s.estop_subdevice = static_cast<int>(kControl);  // an output
  for (const auto& c : cases) {
    std::string message;
    try {
      (void)comedi::open_digital_lines(c.s);
    } catch (const config::ConfigError& e) {
      message = e.what();
    }
    check(message.find(c.key) != std::string::npos && message.find("allowed") != std::string::npos,
          fmt::format("a config naming what the port lacks is refused naming {}: {}", c.key,
                      message));
  }
}

/// Enable and sync on the data lines; a press drops the enable by itself and
/// latches; the reset is refused while held and clears after the release.
void check_lines(Bench& bench) {
  bench.button(false);
  const auto lines = comedi::open_digital_lines(line_settings());
  const bool idle = bench.data_line(kEnable) == 0 && bench.data_line(kSync) == 0;
  (void)lines->set_amplifier_enable(true);
  (void)lines->set_sync(true);
  const bool on = bench.data_line(kEnable) == 1 && bench.data_line(kSync) == 1;
  (void)lines->set_sync(false);
  check(idle && on && bench.data_line(kSync) == 0 && !lines->poll_estop().pressed,
        "enable and sync start low on the data lines, go high when asked, and the released "
        "button reads released");

  // The watcher alone (nobody polls): the enable must drop within its period.
  const auto pressed_at = std::chrono::steady_clock::now();
  bench.button(true);
  double dropped_ms = NAN;
  while (std::chrono::steady_clock::now() - pressed_at < std::chrono::seconds(2)) {
    if (bench.data_line(kEnable) == 0) {
      dropped_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - pressed_at)
              .count();
      break;
    }
  }
  check(bench.busy() == 0 && std::isfinite(dropped_ms),
        fmt::format("a press (busy reads {}) drops the enable line by itself {:.1f} ms later",
                    bench.busy(), dropped_ms));
  const bool refused = !lines->reset_estop();
  (void)lines->set_amplifier_enable(true);
  const bool held_off = bench.data_line(kEnable) == 0;
  bench.button(false);
  std::this_thread::sleep_for(milliseconds(20));
  (void)lines->set_amplifier_enable(true);
  const bool latched = bench.data_line(kEnable) == 0;
  const bool reset = lines->reset_estop();
  (void)lines->set_amplifier_enable(true);
  const bool again = bench.data_line(kEnable) == 1;
  (void)lines->set_amplifier_enable(false);
  check(refused && held_off && latched && reset && again,
        fmt::format("the press latches: reset refused while held ({}), enable held off ({}) and "
                    "still off once released ({}) until the reset ({}), then enabled again ({})",
                    refused, held_off, latched, reset, again));
}

/// A whole drive loop on the card's clocked output with the lines on the
/// port: the button pressed mid-run ends it `estop`, the enable line low
/// and the card's output at 0 V (read back through comedi_test's loopback).
void check_run(Bench& bench) {
  bench.button(false);
  hal::posix::MonotonicClock clock;
  comedi::AnalogOutputSettings out;
  out.output = {kCard, -1, 0, 0};
  out.rate_hz = 2000.0;
  out.preload_s = 0.05;
  out.amplifier_gain = kGain;
  out.readback = {kCard, 0, 0, 0};
  comedi::ComediAnalogOutput drive(out);
  hal::sim::NullSensor sensor(clock);
  const auto lines = comedi::open_digital_lines(line_settings());
  firmware::LoopRunnerSettings s;
  s.drive = {2000.0, 30.0};
  s.sensor_rate_hz = 1000.0;
  s.realtime = false;  // the guest is emulated
  firmware::SafetySettings safety;
  safety.ramp_down_V_per_s = 1000.0;
  const model::Sawtooth saw(80.0, 20.0, 0.75);
  firmware::WaveformProgram program(saw);
  std::vector<firmware::RunAxis> axes{
      {drive, sensor, program, {0.0, 80.0, 20'000.0}, 0.05, safety}};
  firmware::LoopRunner runner(s, std::move(axes), clock, *lines);
  comedi::ComediDevice card(kCard);
  comedi_polynomial_t to_volts = card.converter(0, 0, 0, COMEDI_TO_PHYSICAL);
  const auto card_V = [&] {
    lsampl_t raw = 0;
    (void)comedi_data_read(card.get(), 0, 0, 0, AREF_GROUND, &raw);
    return comedi_to_physical(raw, &to_volts);
  };
  (void)runner.start({});
  std::this_thread::sleep_for(milliseconds(600));
  const int enabled = bench.data_line(kEnable);
  const double moving_V = card_V();
  // The device side: from the press to the enable line low and to the
  // card's output at 0 V (the preload queued ahead is cancelled, not played).
  const auto pressed_at = std::chrono::steady_clock::now();
  bench.button(true);
  const auto since_ms = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - pressed_at)
        .count();
  };
  double enable_low_ms = NAN, zero_ms = NAN;
  while (since_ms() < 5000.0 && !(std::isfinite(enable_low_ms) && std::isfinite(zero_ms))) {
    if (!std::isfinite(enable_low_ms) && bench.data_line(kEnable) == 0) enable_low_ms = since_ms();
    if (!std::isfinite(zero_ms) && std::abs(card_V()) < 0.01) zero_ms = since_ms();
  }
  runner.join();
  runner.drain(
      0, [](const firmware::DriveSample&) {}, [](const firmware::SensorSample&) {});
  const double end_V = card_V();
  check(enabled == 1 && runner.cause() == firmware::StopCause::estop &&
            bench.data_line(kEnable) == 0 && std::abs(end_V) < 0.01 &&
            runner.outcome().zero_confirmed && runner.outcome().zero_read_back,
        fmt::format("the button pressed mid-run (enable was {}, the card at {:.2f} V, {:g} ms "
                    "queued ahead): cause {}, the enable line low {:.1f} ms and the card's "
                    "output at 0 V {:.1f} ms after the press, ending at {:.4f} V (read back)",
                    enabled, moving_V, 1e3 * out.preload_s, firmware::to_string(runner.cause()),
                    enable_low_ms, zero_ms, end_V));
  bench.button(false);
}

}  // namespace

int main() {
  try {
    check(attach_parport(), "comedi_parport attached at 0x378 as /dev/comedi0");
    Bench bench;
    check_refused();
    check_lines(bench);
    check_run(bench);
  } catch (const std::exception& e) {
    check(false, std::string("exception: ") + e.what());
  }
  fmt::print("lines checks done: {} failed\n", g_failures);
  return g_failures;
}
