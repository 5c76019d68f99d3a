// Position compare on its own: pulses at measured angles, once per
// position, whatever the angle does in between.

#include "piezo/firmware/position_compare.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace piezo::firmware {
namespace {

constexpr double kTick = 1e-4;

/// Feeds `angles` one reading per millisecond and runs the ticks between;
/// returns the pulses as they went out and counts the line's rising edges.
struct Line {
  std::vector<TriggerPulse> pulses;
  int edges = 0;
  bool level = false;
  double t = 0.0;

  void run(PositionCompare& c, const std::vector<double>& angles, int ticks_after = 200) {
    for (const double a : angles) {
      c.on_angle(a, static_cast<std::int64_t>(t * 1e9));
      ticks(c, 10);
    }
    ticks(c, ticks_after);
  }
  void ticks(PositionCompare& c, int n) {
    for (int i = 0; i < n; ++i, t += kTick) {
      bool now = false;
      TriggerPulse p;
      if (c.tick(t, now, p)) pulses.push_back(p);
      if (now && !level) ++edges;
      level = now;
    }
  }
};

CompareSettings every_mrad(int pulses) {
  CompareSettings s;
  s.start_rad = 0.010;
  s.step_rad = 0.001;
  s.pulses = static_cast<std::uint32_t>(pulses);
  s.width_s = 2e-4;
  return s;
}

TEST(PositionCompare, EachPositionFiresOnceAlthoughTheRotorSlipsBack) {
  PositionCompare c(every_mrad(5));
  // Up 0.3 mrad a reading, back 0.1 mrad every third: each position is
  // passed, crossed back and passed again.
  std::vector<double> angles;
  double a = 0.009;
  for (int i = 0; i < 80; ++i) {
    a += (i % 3 == 2) ? -0.1e-3 : 0.3e-3;
    angles.push_back(a);
  }
  Line line;
  line.run(c, angles);
  ASSERT_EQ(line.pulses.size(), 5u);
  EXPECT_EQ(line.edges, 5) << "one edge on the line per pulse";
  for (std::uint32_t k = 0; k < 5; ++k) {
    const TriggerPulse& p = line.pulses[k];
    EXPECT_EQ(p.k, k);
    EXPECT_DOUBLE_EQ(p.position_rad, 0.010 + 0.001 * k);
    EXPECT_GE(p.angle_rad, p.position_rad) << "fired by the reading that passed it";
    EXPECT_LT(p.angle_rad - p.position_rad, 0.3e-3 + 1e-12) << "within one reading's travel";
    EXPECT_FALSE(p.late);
  }
  EXPECT_TRUE(c.done());
}

TEST(PositionCompare, PositionsPassedBetweenTwoReadingsFireOnceEachAndAreLate) {
  PositionCompare c(every_mrad(6));
  Line line;
  line.run(c, {0.0095, 0.0121, 0.0122, 0.0156});  // 3 positions, none, then 3
  ASSERT_EQ(line.pulses.size(), 6u);
  EXPECT_EQ(line.edges, 6) << "separate edges, however close";
  int late = 0;
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(line.pulses[i].k, i);
    if (line.pulses[i].late) ++late;
    if (i > 0) {
      EXPECT_GE(line.pulses[i].edge_s - line.pulses[i - 1].edge_s, 2 * 2e-4 - 1e-9)
          << "high for width, low for width";
    }
  }
  EXPECT_EQ(late, 4) << "k 1, 2 (with k 0) and 4, 5 (with k 3)";
}

TEST(PositionCompare, ArmsOnlyOnceTheAngleWasPreStartBeforeStart) {
  CompareSettings s = every_mrad(3);
  s.pre_start_rad = 0.002;
  PositionCompare c(s);
  Line line;
  line.run(c, {0.0095, 0.0105, 0.0125});  // never 2 mrad before start: not armed
  EXPECT_FALSE(c.armed());
  EXPECT_TRUE(line.pulses.empty());
  line.run(c, {0.0079, 0.0105, 0.0125});
  EXPECT_TRUE(c.armed());
  EXPECT_EQ(line.pulses.size(), 3u);
}

TEST(PositionCompare, FallingScansFireAsTheAngleFalls) {
  CompareSettings s = every_mrad(3);
  s.direction = -1;
  PositionCompare c(s);
  Line line;
  line.run(c, {0.0105, 0.0099, 0.0091, 0.0089, 0.0081, 0.0079, 0.0010});
  ASSERT_EQ(line.pulses.size(), 3u);
  EXPECT_DOUBLE_EQ(line.pulses[2].position_rad, 0.008);
  EXPECT_LE(line.pulses[2].angle_rad, 0.008);
  EXPECT_EQ(c.next_k(), 3u) << "no position beyond the last";
}

TEST(PositionCompare, AFullQueueHoldsPositionsBackInsteadOfDroppingThem) {
  CompareSettings s = every_mrad(PositionCompare::kQueue + 10);
  PositionCompare c(s);
  Line line;
  line.run(c, {0.0, 1.0}, 0);  // every position at once
  EXPECT_EQ(c.next_k(), static_cast<std::uint32_t>(PositionCompare::kQueue));
  // The rest wait for the readings after it.
  line.run(c, std::vector<double>(40, 1.0));
  EXPECT_EQ(line.pulses.size(), static_cast<std::size_t>(PositionCompare::kQueue + 10));
  EXPECT_EQ(line.edges, PositionCompare::kQueue + 10);
}

}  // namespace
}  // namespace piezo::firmware
