// The one progress rule (ProgressJudge) on made-up units: what it calls
// progress, a stall, a frozen or blind sensor and motion against the drive,
// and the floors it takes them from.

#include "piezo/firmware/progress_judge.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace piezo::firmware {
namespace {

using Verdict = ProgressJudge::Verdict;

// A stroke of 2.5 mrad, no noise: the swing floor is 5 % of it (125 urad),
// the progress floor the resolution (50 urad).
const ProgressFloors kFloors{0.0, 0.062, 2.5e-3, 50e-6};

/// Units of `gain` each, swinging by `swing` within each, with `readings`
/// readings in each and a change among them unless `frozen`; the verdict
/// after `units` of them (K = 2).
Verdict after(int units, double gain, double swing, bool frozen = false,
              std::uint64_t readings = 10) {
  ProgressJudge judge;
  judge.begin(2, 0.0, {});
  Verdict v = Verdict::progressing;
  double theta = 0.0;
  ReadingCounts counts;
  for (int i = 0; i < units; ++i) {
    theta += gain;
    counts.readings += readings;
    if (!frozen) counts.changes += readings;
    v = judge.end_unit(theta, counts, theta - swing, theta + swing, 1.0, kFloors);
  }
  return v;
}

TEST(ProgressJudge, StepsThatGainAreProgress) {
  EXPECT_EQ(after(5, 1e-3, 1e-3), Verdict::progressing);
}

TEST(ProgressJudge, ProgressIsJudgedOverKUnitsASensorInEach) {
  EXPECT_EQ(after(1, 0.0, 1e-3), Verdict::progressing) << "no progress yet judged";
  EXPECT_EQ(after(1, 1e-3, 1e-3, true), Verdict::implausible) << "frozen in one unit";
  EXPECT_EQ(after(1, 1e-3, 10e-6), Verdict::implausible) << "blind in one unit";
}

// A loaded line may deliver no reading, or one, in a step: that is no
// frozen or blind sensor (a late or silent one is the staleness limit's).
TEST(ProgressJudge, UnitsWithoutTwoReadingsAreNotJudgedTheSensors) {
  EXPECT_EQ(after(1, 0.0, 0.0, true, 0), Verdict::progressing) << "no reading in the unit";
  EXPECT_EQ(after(1, 0.0, 0.0, true, 1), Verdict::progressing) << "one reading in the unit";
  EXPECT_EQ(after(3, 0.0, 0.0, true, 0), Verdict::progressing) << "none in K units";
  EXPECT_EQ(after(1, 0.0, 0.0, true, 2), Verdict::implausible) << "two, equal: frozen";
  EXPECT_EQ(after(2, 0.0, 0.0, true, 1), Verdict::implausible) << "one a unit, equal over K";
}

TEST(ProgressJudge, GainBelowTheFloorIsAStall) {
  EXPECT_EQ(after(2, 20e-6, 1e-3), Verdict::stalled);  // 40 urad over 2 units < 50
  EXPECT_EQ(after(2, 30e-6, 1e-3), Verdict::progressing);
}

TEST(ProgressJudge, AFrozenABlindOrABackwardSensorIsImplausible) {
  EXPECT_EQ(after(2, 1e-3, 1e-3, true), Verdict::implausible);  // no reading changed
  EXPECT_EQ(after(2, 0.0, 10e-6), Verdict::implausible);        // swung under the floor
  EXPECT_EQ(after(2, -1.5e-3, 1e-3), Verdict::implausible);     // 3 mrad back > 0.25*2*2.5
  EXPECT_EQ(after(2, -0.5e-3, 1e-3), Verdict::stalled);         // back, but not that far
}

TEST(ProgressJudge, TheFloorsTakeTheLargerOfNoiseAndStroke) {
  ProgressFloors f = kFloors;
  EXPECT_DOUBLE_EQ(ProgressJudge::progress_floor(f), 50e-6);
  EXPECT_DOUBLE_EQ(ProgressJudge::swing_floor(f), 0.05 * 2.5e-3);
  f.noise_m = 10e-6;  // 161 urad a reading: its 8-reading mean's 4 sd is 228 urad
  EXPECT_NEAR(ProgressJudge::progress_floor(f), 4.0 * 10e-6 / 0.062 / std::sqrt(8.0), 1e-12);
  EXPECT_NEAR(ProgressJudge::swing_floor(f), 8.0 * 10e-6 / 0.062, 1e-12);
}

TEST(ReadingWindow, MeansTheLastEightAndCountsReadingsAndChanges) {
  ReadingWindow w;
  EXPECT_DOUBLE_EQ(w.add(1.0), 1.0);
  EXPECT_DOUBLE_EQ(w.add(3.0), 2.0);
  for (int i = 0; i < 8; ++i) (void)w.add(5.0);
  EXPECT_TRUE(w.full());
  EXPECT_DOUBLE_EQ(w.add(5.0), 5.0);
  EXPECT_EQ(w.counts().readings, 11u);
  EXPECT_EQ(w.counts().changes, 2u);  // 1 -> 3 -> 5
}

}  // namespace
}  // namespace piezo::firmware
