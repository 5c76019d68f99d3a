// The DAQ card's stream arithmetic without a card: the preload's depth and
// latency, the drift keeper against a card that takes samples in bursts on
// a clock that runs fast or slow, and the sensor's span and rails.

#include "piezo/hal/comedi/daq_arithmetic.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

namespace piezo::hal::comedi {
namespace {

TEST(DaqArithmetic, ThePreloadIsWholeSamplesAndItsLatencyFollows) {
  EXPECT_EQ(preload_samples(0.01, 10'000.0), 100u);
  EXPECT_EQ(preload_samples(0.0001, 1'000.0), 2u);  // never fewer than two
  EXPECT_DOUBLE_EQ(preload_latency_s(100, 10'000.0), 0.01);
}

/// A card that takes `burst` samples at once every `burst` of its ticks,
/// its clock `ppm` off the loop's, fed one write per loop tick for `seconds`.
struct Feed {
  long lowest = 1 << 30, highest = 0;
  bool ran_dry = false;
};

Feed feed(double ppm, std::size_t burst, double seconds) {
  constexpr double kRate = 10'000.0;
  constexpr std::size_t kPreload = 200;
  DriftKeeper keeper(kPreload, 1000);
  long queued = kPreload;
  double card_ticks = 0.0;
  std::uint64_t taken = 0;
  Feed out;
  const auto loop_ticks = static_cast<std::uint64_t>(seconds * kRate);
  for (std::uint64_t i = 0; i < loop_ticks; ++i) {
    card_ticks += 1.0 + ppm * 1e-6;
    // The card takes whole bursts of the samples due by its clock.
    while (static_cast<double>(taken + burst) <= card_ticks) {
      queued -= static_cast<long>(burst);
      taken += burst;
      if (queued < 0) out.ran_dry = true;
    }
    out.lowest = std::min(out.lowest, queued);
    queued += static_cast<long>(keeper.copies(static_cast<std::size_t>(std::max(0L, queued))));
    out.highest = std::max(out.highest, queued);
  }
  return out;
}

// Over ten simulated minutes a card 200 ppm fast or slow would gain or lose
// 1,200 samples (six preloads) without correction; the keeper holds the
// level within a quarter of the preload (and a burst) of where it started.
TEST(DaqArithmetic, TheDriftKeeperHoldsTheQueueAgainstAFastOrSlowCard) {
  for (const double ppm : {-200.0, 0.0, 200.0}) {
    for (const std::size_t burst : {1u, 40u}) {
      const Feed f = feed(ppm, burst, 600.0);
      EXPECT_FALSE(f.ran_dry) << ppm << " ppm, bursts of " << burst;
      EXPECT_GE(f.lowest, 200 - static_cast<long>(burst) - 50 - 2) << ppm << " ppm";
      EXPECT_LE(f.highest, 200 + static_cast<long>(burst) + 50 + 2) << ppm << " ppm";
    }
  }
}

// Without the keeper (one copy a write, always) the same fast card runs dry:
// the test above can fail.
TEST(DaqArithmetic, WithoutCorrectionAFastCardRunsDry) {
  long queued = 200;
  for (int i = 0; i < 6'000'000; ++i) {
    if (i % 5000 == 0) --queued;  // 200 ppm: one extra sample taken in 5,000
  }
  EXPECT_LT(queued, 0);
}

TEST(DaqArithmetic, TheSpanMapsVoltsOntoTheMeasuringRangeEitherWayRound) {
  // A 4-20 mA sensor across 250 ohm: 1-5 V for 30-70 mm.
  const AnalogSpan span{1.0, 5.0, 0.030, 0.070};
  EXPECT_DOUBLE_EQ(span.distance_m(1.0), 0.030);
  EXPECT_DOUBLE_EQ(span.distance_m(3.0), 0.050);
  EXPECT_TRUE(span.admits(5.0));
  EXPECT_FALSE(span.admits(0.5));  // below 4 mA: a broken loop
  EXPECT_FALSE(span.admits(5.2));
  const AnalogSpan falling{10.0, 0.0, 0.0, 0.01};  // the output falls as the distance grows
  EXPECT_DOUBLE_EQ(falling.distance_m(2.5), 0.0075);
  EXPECT_TRUE(falling.admits(2.5));
}

TEST(DaqArithmetic, ARawSampleAtEitherRailIsNoReading) {
  EXPECT_TRUE(at_rail(0, 65535));
  EXPECT_TRUE(at_rail(65535, 65535));
  EXPECT_FALSE(at_rail(1, 65535));
  EXPECT_FALSE(at_rail(32768, 65535));
}

}  // namespace
}  // namespace piezo::hal::comedi
