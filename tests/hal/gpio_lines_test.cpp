// The logic above the libgpiod adapter, on simulated lines: DAC codes, bit
// order, strobe sequence and polarity; the levels lines are requested at;
// enable, sync and e-stop; an e-stop edge reaching the safety supervisor
// within one drive period, and dropping the enable line by itself while
// the drive loop is blocked in a slow drive write.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "../support/emulation.hpp"
#include "piezo/firmware/drive_loop.hpp"
#include "piezo/hal/gpio/gpio_digital_lines.hpp"
#include "piezo/hal/gpio/parallel_dac.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/null_drive.hpp"
#include "piezo/hal/sim/sim_line_group.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"

namespace piezo::hal::gpio {
namespace {

using sim::RecordingOutputLines;
using sim::SimInputLine;

std::vector<int> bits_lsb_first(std::uint32_t code, int n) {
  std::vector<int> out;
  for (int i = 0; i < n; ++i) out.push_back(static_cast<int>((code >> i) & 1u));
  return out;
}

TEST(ParallelDac, CodeGoesOutLsbFirstThenTheStrobePulses) {
  RecordingOutputLines lines(13);
  ParallelDac dac({.bits = 12,
                   .has_strobe = true,
                   .data_active_low = false,
                   .strobe_active_low = true,
                   .full_scale_V = 5.0,
                   .amplifier_gain = 20.0},
                  lines);
  EXPECT_EQ(dac.write(40.0), Status::ok);  // 2 V at the DAC: round(2/5 * 4095) = 1638
  EXPECT_EQ(dac.code_for(40.0), 1638u);
  auto data = bits_lsb_first(1638, 12);
  auto with = [&](int strobe) {
    auto v = data;
    v.push_back(strobe);
    return v;
  };
  // Active-low WR: idle high, pulse low, back high (the DAC latches on the rising edge).
  EXPECT_EQ(lines.writes(), (std::vector<std::vector<int>>{with(1), with(0), with(1)}));
}

TEST(ParallelDac, MostSignificantBitIsTheLastDataLine) {
  RecordingOutputLines lines(8);
  ParallelDac dac({.bits = 8, .has_strobe = false, .full_scale_V = 5.0, .amplifier_gain = 20.0},
                  lines);
  EXPECT_EQ(dac.write(100.0 * 128.0 / 255.0), Status::ok);  // code 128: only the MSB
  ASSERT_EQ(lines.writes().size(), 1u) << "no strobe: one bulk write";
  EXPECT_EQ(lines.writes()[0], (std::vector<int>{0, 0, 0, 0, 0, 0, 0, 1}));
}

TEST(ParallelDac, ActiveLowDataInvertsEveryBitAndAnActiveHighStrobePulsesHigh) {
  RecordingOutputLines lines(5);
  ParallelDac dac({.bits = 4,
                   .has_strobe = true,
                   .data_active_low = true,
                   .strobe_active_low = false,
                   .full_scale_V = 5.0,
                   .amplifier_gain = 20.0},
                  lines);
  EXPECT_EQ(dac.write(100.0), Status::ok);  // code 15: all ones, sent as lows
  EXPECT_EQ(lines.writes(),
            (std::vector<std::vector<int>>{{0, 0, 0, 0, 0}, {0, 0, 0, 0, 1}, {0, 0, 0, 0, 0}}));
}

TEST(ParallelDac, RefusesVoltagesOutsideItsRangeWithoutTouchingTheLines) {
  RecordingOutputLines lines(13);
  ParallelDac dac({}, lines);
  EXPECT_EQ(dac.write(-1.0), Status::out_of_range);
  EXPECT_EQ(dac.write(101.0), Status::out_of_range);
  EXPECT_TRUE(lines.writes().empty());
  EXPECT_DOUBLE_EQ(dac.limits().V_max, 100.0);
}

TEST(ParallelDac, RefusesTheWrongNumberOfLines) {
  RecordingOutputLines lines(12);
  EXPECT_THROW(ParallelDac({.bits = 12, .has_strobe = true}, lines), std::invalid_argument);
}

TEST(GpioDigitalLines, PolarityOfEnableAndSync) {
  RecordingOutputLines outputs(2);
  GpioDigitalLines lines({.has_sync = true, .enable_active_low = true, .sync_active_low = false},
                         outputs, nullptr);
  EXPECT_EQ(lines.set_amplifier_enable(true), Status::ok);
  EXPECT_EQ(lines.set_sync(true), Status::ok);
  EXPECT_EQ(lines.set_sync(false), Status::ok);
  EXPECT_EQ(lines.set_amplifier_enable(false), Status::ok);
  EXPECT_EQ(outputs.writes(), (std::vector<std::vector<int>>{{0, 0}, {0, 1}, {0, 0}, {1, 0}}));
  EXPECT_FALSE(lines.poll_estop().pressed) << "no e-stop wired";
}

// The protocol's e-stop: trip() drops the enable line from the caller's
// thread, the loop's sync and enable writes keep it down, and only the next
// run's enable raises it again (unlike the e-stop input, which latches).
TEST(GpioDigitalLines, ATripHoldsTheEnableDownUntilTheNextRunEnables) {
  RecordingOutputLines outputs(2);
  GpioDigitalLines lines({.has_sync = true, .enable_active_low = true, .sync_active_low = false},
                         outputs, nullptr);
  EXPECT_EQ(lines.set_amplifier_enable(true), Status::ok);   // {0, 0}: enabled (active low)
  EXPECT_TRUE(lines.trip());                                 // {1, 0}
  EXPECT_EQ(lines.set_sync(true), Status::ok);               // {1, 1}: still disabled
  EXPECT_EQ(lines.set_amplifier_enable(false), Status::ok);  // {1, 1}
  EXPECT_FALSE(lines.poll_estop().edge_seen) << "a trip is no e-stop press";
  EXPECT_EQ(lines.set_amplifier_enable(true), Status::ok);  // {0, 1}: the next run
  EXPECT_EQ(outputs.writes(),
            (std::vector<std::vector<int>>{{0, 0}, {1, 0}, {1, 1}, {1, 1}, {0, 1}}));
}

TEST(GpioDigitalLines, EstopLevelAndEdges) {
  RecordingOutputLines outputs(1);
  SimInputLine estop(1);  // normally closed, pulled up: released = high
  GpioDigitalLines lines({.has_sync = false, .estop_active_low = true}, outputs, &estop);
  EstopState s = lines.poll_estop();
  EXPECT_FALSE(s.pressed);
  EXPECT_FALSE(s.edge_seen);
  estop.drive(0);
  s = lines.poll_estop();
  EXPECT_TRUE(s.pressed);
  EXPECT_TRUE(s.edge_seen);
  estop.drive(1);  // a press released before the next poll still leaves its edge
  estop.drive(0);
  estop.drive(1);
  s = lines.poll_estop();
  EXPECT_FALSE(s.pressed);
  EXPECT_TRUE(s.edge_seen);
}

// A press latches: the enable stays down after the button is released, a
// reset is refused while it is held, and once released and reset the next
// run enables again; a later press trips again.
TEST(GpioDigitalLines, AnEstopPressLatchesUntilReleasedAndReset) {
  RecordingOutputLines outputs(1);
  SimInputLine estop(1);  // normally closed, pulled up: released = high
  GpioDigitalLines lines({.has_sync = false, .estop_active_low = true}, outputs, &estop);
  const auto enable_level = [&] { return outputs.level(0); };  // locked: the watcher writes too
  EXPECT_TRUE(lines.reset_estop()) << "nothing latched: a reset is harmless";
  ASSERT_EQ(lines.set_amplifier_enable(true), Status::ok);
  EXPECT_EQ(enable_level(), 1);

  estop.drive(0);
  EXPECT_TRUE(lines.poll_estop().edge_seen);
  EXPECT_EQ(enable_level(), 0);
  EXPECT_FALSE(lines.reset_estop()) << "held: refused";
  (void)lines.set_amplifier_enable(true);
  EXPECT_EQ(enable_level(), 0) << "a run cannot enable while the press is latched";

  estop.drive(1);
  EXPECT_TRUE(lines.poll_estop().edge_seen) << "released, still latched";
  (void)lines.set_amplifier_enable(true);
  EXPECT_EQ(enable_level(), 0);

  EXPECT_TRUE(lines.reset_estop());
  const EstopState after = lines.poll_estop();
  EXPECT_FALSE(after.pressed);
  EXPECT_FALSE(after.edge_seen);
  (void)lines.set_amplifier_enable(true);
  EXPECT_EQ(enable_level(), 1) << "the next run enables";

  estop.drive(0);
  EXPECT_TRUE(lines.poll_estop().edge_seen);
  EXPECT_EQ(enable_level(), 0) << "a new press trips again";
}

// The e-stop pressed at 0.5 s on the virtual clock: the enable line must
// fall within one 100 us drive period.
TEST(GpioDigitalLines, AnEstopEdgeDropsTheEnableLineWithinOneDrivePeriod) {
  sim::VirtualClock clock;
  RecordingOutputLines outputs(2, &clock);
  SimInputLine estop(1);
  GpioDigitalLines lines({.has_sync = true, .estop_active_low = true}, outputs, &estop);
  sim::NullDrive drive(clock);
  firmware::SpscRing<firmware::DriveSample> ring(1 << 14);
  firmware::SensorHealth health;
  firmware::SafetySettings safety;
  safety.sensor_stale_s = 1e9;
  const TimeNs t0 = 1'000'000;
  firmware::SafetySupervisor supervisor(safety, health, t0);
  const model::Sawtooth saw(80.0, 10.0, 0.75);
  const std::atomic<bool> stop{false};
  firmware::WaveformProgram program(saw);
  firmware::DriveLoop loop({10'000.0, 10.0},
                           {{0.0, 80.0, 20'000.0}, 0.1, &program, &supervisor, &drive, &ring},
                           {clock, lines, stop, stop});
  const TimeNs press_at = t0 + 500'000'000 + 37'000;  // between two drive deadlines
  SleeperScope loop_scope(clock), presser_scope(clock);
  std::thread presser([&, scope = std::move(presser_scope)]() mutable {
    const SleeperScope mine(std::move(scope));
    clock.sleep_until(press_at);
    estop.drive(0);
  });
  firmware::StopCause cause{};
  std::thread driver([&, scope = std::move(loop_scope)]() mutable {
    const SleeperScope mine(std::move(scope));
    cause = loop.run(t0);
  });
  presser.join();
  driver.join();
  EXPECT_EQ(cause, firmware::StopCause::estop);
  ASSERT_FALSE(outputs.writes().empty());
  EXPECT_EQ(outputs.writes().back()[0], 0) << "enable low (active high)";
  const TimeNs dropped_at = outputs.times().back();
  EXPECT_GE(dropped_at, press_at);
  EXPECT_LE(dropped_at - press_at, 100'000) << "within one drive period";
}

// Lines are requested at these levels: nothing enabled, 0 V, strobe idle,
// in every polarity (what the gpiod adapter hands the kernel).
TEST(GpioLevels, IdleLevelsAreInactiveInEveryPolarity) {
  EXPECT_EQ(GpioDigitalLines::idle_levels({.has_sync = true}), (std::vector<int>{0, 0}));
  EXPECT_EQ(GpioDigitalLines::idle_levels(
                {.has_sync = true, .enable_active_low = true, .sync_active_low = true}),
            (std::vector<int>{1, 1}));
  EXPECT_EQ(GpioDigitalLines::idle_levels({.has_sync = false, .enable_active_low = true}),
            (std::vector<int>{1}));
  EXPECT_EQ(
      ParallelDac::idle_levels(
          {.bits = 4, .has_strobe = true, .data_active_low = false, .strobe_active_low = true}),
      (std::vector<int>{0, 0, 0, 0, 1}));
  EXPECT_EQ(
      ParallelDac::idle_levels(
          {.bits = 4, .has_strobe = true, .data_active_low = true, .strobe_active_low = false}),
      (std::vector<int>{1, 1, 1, 1, 0}));
  // The idle data levels are the code for 0 V.
  RecordingOutputLines lines(5);
  ParallelDac dac({.bits = 4, .has_strobe = true, .data_active_low = true}, lines);
  ASSERT_EQ(dac.write(0.0), Status::ok);
  EXPECT_EQ(lines.writes().back(),
            ParallelDac::idle_levels({.bits = 4, .has_strobe = true, .data_active_low = true}));
}

// A drive whose writes block 300 ms (a slow analog-output module): the
// e-stop must not wait for the write. Its watcher drops the enable line
// (active low: physical high) while the loop is still inside the write.
TEST(GpioDigitalLines, AnEstopDropsTheEnableLineWhileTheDriveWriteBlocks) {
  PIEZO_SKIP_TIMING_UNDER_EMULATION();
  posix::MonotonicClock clock;
  RecordingOutputLines outputs(2, &clock);
  SimInputLine estop(1);
  GpioDigitalLines lines({.has_sync = true, .enable_active_low = true, .estop_active_low = true},
                         outputs, &estop);
  constexpr double kWriteLatency_s = 0.3;
  sim::NullDrive drive(clock, kWriteLatency_s);
  firmware::SpscRing<firmware::DriveSample> ring(1 << 10);
  firmware::SensorHealth health;
  firmware::SafetySettings safety;
  safety.sensor_stale_s = 1e9;
  const TimeNs t0 = clock.now();
  firmware::SafetySupervisor supervisor(safety, health, t0);
  const model::Sawtooth saw(80.0, 10.0, 0.75);
  const std::atomic<bool> stop{false};
  firmware::WaveformProgram program(saw);
  firmware::DriveLoop loop({1000.0, 10.0},
                           {{0.0, 80.0, 1e6}, 0.1, &program, &supervisor, &drive, &ring},
                           {clock, lines, stop, stop});
  std::thread driver([&] { (void)loop.run(t0); });
  // The first write (0 V before enabling) and the enable, then the loop's
  // first cycle blocks in its write for 300 ms: press in the middle of it.
  while (outputs.level(0) != 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const TimeNs pressed_at = clock.now();
  estop.drive(0);
  while (outputs.level(0) != 1) std::this_thread::sleep_for(std::chrono::microseconds(100));
  const TimeNs disabled_at = clock.now();
  const std::size_t ring_before = ring.size_approx();
  driver.join();
  EXPECT_EQ(outputs.level(0), 1) << "enable released (active low: high) at the end";
  // The enable fell before the blocked write could return: the drive loop
  // pushed nothing in between and needed the rest of its write to notice.
  EXPECT_EQ(ring_before, 0u) << "the loop was still inside its first cycle's write";
  EXPECT_EQ(supervisor.cause(), firmware::StopCause::estop);
  std::printf("press to enable low: %.3f ms with a %.0f ms drive write\n",
              1e3 * to_seconds(disabled_at - pressed_at), 1e3 * kWriteLatency_s);
}

}  // namespace
}  // namespace piezo::hal::gpio
