// The web view's pieces that need no browser: min/max decimation, the live
// feed's window, and the run names a request may ask for.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "decimate.hpp"
#include "live_feed.hpp"
#include "run_catalogue.hpp"

namespace piezo::host::view {
namespace {

TEST(Decimate, KeepsEachColumnsMinimumAndMaximumInTimeOrder) {
  std::vector<double> t, y;
  for (int i = 0; i < 1000; ++i) {
    t.push_back(i * 1e-3);
    y.push_back(i == 437 ? 50.0 : std::sin(i * 0.01));  // one spike
  }
  const Series s = min_max_decimate(t, y, 0.0, 1.0, 10);
  EXPECT_LE(s.t.size(), 20u);
  EXPECT_NE(std::find(s.y.begin(), s.y.end(), 50.0), s.y.end()) << "the spike survives";
  EXPECT_TRUE(std::is_sorted(s.t.begin(), s.t.end()));
}

// Samples on the columns' boundaries (where a separately computed boundary
// can disagree with the column by a rounding) are each taken once.
TEST(Decimate, SamplesOnColumnBoundariesAreTakenOnce) {
  std::vector<double> t, y;
  for (int i = 0; i <= 30000; ++i) {
    t.push_back(1.7353 + i * 1e-4);
    y.push_back(i % 7);
  }
  const Series s = min_max_decimate(t, y, 1.7353, 4.7353, 800);
  EXPECT_GT(s.t.size(), 800u);
  EXPECT_LE(s.t.size(), 1600u);
}

TEST(Decimate, SkipsFailedReadingsAndEmptyInput) {
  const std::vector<double> t{0.0, 0.1, 0.2}, y{NAN, 1.0, NAN};
  const Series s = min_max_decimate(t, y, 0.0, 0.3, 1);
  ASSERT_EQ(s.y.size(), 1u);
  EXPECT_EQ(s.y[0], 1.0);
  EXPECT_TRUE(min_max_decimate({}, {}, 0.0, 1.0, 10).t.empty());
}

TEST(LiveFeed, KeepsTheWindowAndZoomsOnTheLastPeriods) {
  LiveFeed feed(2.0, 0.3);
  log_schema::LogRows rows;
  for (int i = 0; i < 100'000; ++i) {  // 10 s at 10 kHz
    rows.drive.t.push_back(i * 1e-4);
    rows.drive.V.push_back(i % 1000 * 0.08);
  }
  feed.add(rows);
  const auto snap = feed.snapshot(100);
  EXPECT_NEAR(snap.at("t_end").get<double>(), 9.9999, 1e-9);
  EXPECT_GE(snap.at("drive").at("t").front().get<double>(), 7.9999 - 1e-9);
  EXPECT_LE(snap.at("drive").at("t").size(), 200u);
  EXPECT_EQ(snap.at("zoom").at("t").size(), 3001u) << "0.3 s at full rate";
}

TEST(RunCatalogue, OnlyPlainRunNamesInsideTheDirectory) {
  const auto dir = std::filesystem::temp_directory_path() / "piezo-view-test-runs";
  std::filesystem::create_directories(dir / "r1");
  std::ofstream(dir / "r1" / "run.h5") << "x";
  EXPECT_TRUE(run_path(dir, "r1").has_value());
  for (const char* bad : {"..", ".", "", "../r1", "r1/../r1", "missing"}) {
    EXPECT_FALSE(run_path(dir, bad).has_value()) << bad;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace piezo::host::view
