// What an axis's readings at rest say: its position, its noise, and a move
// at rest reported once, with its size, only when it passes the noise.

#include "piezo/firmware/rest_watch.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace piezo::firmware {
namespace {

constexpr double kNoise_m = 0.5e-6;

class Readings {
 public:
  double next(double at_m) { return at_m + noise_(random_); }

 private:
  std::mt19937_64 random_{11};
  std::normal_distribution<double> noise_{0.0, kNoise_m};
};

TEST(RestWatch, APositionAndANoiseComeFromTheFirstReadings) {
  RestWatch w;
  Readings r;
  EXPECT_FALSE(w.position_m());
  for (std::size_t i = 0; i + 1 < RestWatch::kMean; ++i) (void)w.add(r.next(70e-3));
  EXPECT_FALSE(w.position_m()) << "a position is a mean of kMean readings";
  (void)w.add(r.next(70e-3));
  ASSERT_TRUE(w.position_m());
  EXPECT_NEAR(*w.position_m(), 70e-3, 4 * kNoise_m);
  EXPECT_EQ(*w.reference_m(), *w.position_m()) << "the rest's first position is its reference";
  for (int i = 0; i < 400; ++i) (void)w.add(r.next(70e-3));
  ASSERT_TRUE(w.noise_m());
  EXPECT_NEAR(*w.noise_m(), kNoise_m, 0.4 * kNoise_m);
}

TEST(RestWatch, NoiseAloneIsNeverAMove) {
  RestWatch w;
  Readings r;
  for (int i = 0; i < 20'000; ++i) EXPECT_FALSE(w.add(r.next(70e-3))) << "reading " << i;
  EXPECT_FALSE(w.moved());
}

TEST(RestWatch, ATurnIsReportedOnceWhenOverWithItsSize) {
  RestWatch w;
  Readings r;
  for (int i = 0; i < 40; ++i) ASSERT_FALSE(w.add(r.next(70e-3)));
  const double turn_m = 30e-6;
  int reports = 0;
  RestWatch::Move seen{};
  for (int i = 0; i < 200; ++i) {
    if (const auto m = w.add(r.next(70e-3 + turn_m))) {
      seen = *m;
      ++reports;
      EXPECT_GE(i, static_cast<int>(RestWatch::kMean) - 1) << "not before the window is past it";
    }
  }
  EXPECT_EQ(reports, 1);
  EXPECT_NEAR(seen.moved_m, turn_m, 3 * kNoise_m);
  EXPECT_NEAR(seen.since_rest_m, turn_m, 3 * kNoise_m);
  EXPECT_TRUE(w.moved());
  EXPECT_NEAR(w.since_rest_m(), turn_m, 3 * kNoise_m);

  // A second turn back: its own size; since the rest began, about nothing.
  std::optional<RestWatch::Move> back;
  for (int i = 0; i < 200 && !back; ++i) back = w.add(r.next(70e-3));
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->moved_m, -turn_m, 3 * kNoise_m);
  EXPECT_NEAR(back->since_rest_m, 0.0, 3 * kNoise_m);
}

TEST(RestWatch, AMoveWithinTheThresholdIsNotOne) {
  RestWatch w;
  Readings r;
  for (int i = 0; i < 40; ++i) (void)w.add(r.next(70e-3));
  const double small = 0.5 * w.threshold_m();
  for (int i = 0; i < 400; ++i) EXPECT_FALSE(w.add(r.next(70e-3 + small)));
}

TEST(RestWatch, AQuietSensorStillNeedsTheFloor) {
  RestWatch w;  // a sensor without noise: readings to the last bit
  for (int i = 0; i < 40; ++i) (void)w.add(70e-3);
  EXPECT_EQ(w.threshold_m(), RestWatch::kMovedFloor_m);
  for (int i = 0; i < 40; ++i) EXPECT_FALSE(w.add(70e-3 + 0.5 * RestWatch::kMovedFloor_m));
  std::optional<RestWatch::Move> m;
  for (int i = 0; i < 40 && !m; ++i) m = w.add(70e-3 + 3 * RestWatch::kMovedFloor_m);
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->moved_m, 3 * RestWatch::kMovedFloor_m, 1e-15);
}

TEST(RestWatch, ANewRestTakesANewReference) {
  RestWatch w;
  Readings r;
  for (int i = 0; i < 40; ++i) (void)w.add(r.next(70e-3));
  w.begin();  // a run moved it
  EXPECT_FALSE(w.position_m());
  for (int i = 0; i < 40; ++i)
    EXPECT_FALSE(w.add(r.next(71e-3))) << "the run's move is no move at rest";
  EXPECT_NEAR(*w.reference_m(), 71e-3, 4 * kNoise_m);
  EXPECT_FALSE(w.moved());
}

}  // namespace
}  // namespace piezo::firmware
