// The web view's pieces that need no browser: min/max decimation, the live
// feed's window, and the run names a request may ask for.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <thread>

#include "view/decimate.hpp"
#include "view/gzip_stream.hpp"
#include "view/live_feed.hpp"
#include "view/run_catalogue.hpp"

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
  LiveFeed feed(2.0, 0.3, 100);
  log_schema::LogRows rows;
  for (int i = 0; i < 100'000; ++i) {  // 10 s at 10 kHz
    rows.drive.t.push_back(i * 1e-4);
    rows.drive.V.push_back(i % 1000 * 0.08);
  }
  feed.add(rows);
  const auto snap = feed.snapshot();
  EXPECT_NEAR(snap.at("t_end").get<double>(), 9.9999, 1e-9);
  // One axis as several: its series under `axes`, nothing at the top level.
  EXPECT_FALSE(snap.contains("drive"));
  ASSERT_EQ(snap.at("axes").size(), 1u);
  const auto& axis = snap.at("axes")[0];
  EXPECT_GE(axis.at("drive").at("t").front().get<double>(), 7.9999 - 1e-9);
  EXPECT_LE(axis.at("drive").at("t").size(), 200u);
  const auto& zoom = axis.at("zoom");
  EXPECT_EQ(zoom.at("y").size(), 3001u) << "0.3 s at full rate";
  EXPECT_NEAR(zoom.at("dt").get<double>(), 1e-4, 1e-12) << "a grid goes as start and step";
}

/// Samples as the default configuration logs them: the drive's sawtooth at
/// 10 kHz, the sensor and the observer at 1 kHz, in batches of `batch_s`.
log_schema::LogRows rig_rows(double from, double batch_s) {
  log_schema::LogRows rows;
  for (long i = std::lround(from * 1e4); i < std::lround((from + batch_s) * 1e4); ++i) {
    const double t = static_cast<double>(i) * 1e-4;
    rows.drive.t.push_back(t);
    rows.drive.V.push_back(100.0 * std::fmod(t * 10.0, 1.0));
    if (i % 10 == 0) {
      const double theta = 1e-3 * t + 1e-6 * std::sin(t * 60.0);
      rows.sensor.t.push_back(t);
      rows.sensor.theta.push_back(i % 1000 == 0 ? NAN : theta);
      rows.observer.t.push_back(t);
      rows.observer.theta_hat.push_back(theta * 1.01);
      rows.observer.theta_open.push_back(theta * 0.98);
      rows.observer.residual.push_back(theta * 0.01);
    }
  }
  return rows;
}

/// A status as a run on the simulated rig reports it four times a second:
/// the board's health with both loops' period-error histograms (1 us bins,
/// trimmed after the last non-zero one; some 10 KB each as JSON).
nlohmann::json rig_status(double t) {
  auto histogram = [t](double rate_hz, double spread_us) {
    nlohmann::json bins = nlohmann::json::array();
    for (int us = 0; us < 1200; ++us) {
      bins.push_back(std::round(rate_hz * t * std::exp(-us / spread_us) / spread_us));
    }
    bins.push_back(1.0);  // one late wake-up keeps the tail
    return bins;
  };
  nlohmann::json loop{{"cycles", 10000 * t}, {"overruns", 0},   {"missed_cycles", 0},
                      {"dropped", 0},        {"errors", 0},     {"p50_us", 20.0},
                      {"p99_us", 80.0},      {"max_us", 1200.0}};
  nlohmann::json drive = loop, sensor = loop;
  drive["histogram_us"] = histogram(1e4, 30.0);
  sensor["histogram_us"] = histogram(1e3, 60.0);
  return {{"t_s", t},
          {"V", 50.0},
          {"theta_rad", 1e-3 * t},
          {"board", {{"state", "running"}, {"drive", drive}, {"sensor", sensor}}}};
}

/// A page's window kept as the live page keeps it (live-window.js).
struct PageWindow {
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> series;
  nlohmann::json histograms;
  void apply(const nlohmann::json& e) {
    if (e.contains("histograms")) histograms = e.at("histograms");
    for (const char* name : {"drive", "measured", "observer", "open_loop", "residual"}) {
      auto& [t, y] = series[name];
      if (e.at("reset").get<bool>()) t.clear(), y.clear();
      const double from = e.at("t_end").get<double>() - e.at("window_s").get<double>();
      std::size_t keep = 0;
      while (keep < t.size() && t[keep] < from) ++keep;
      t.erase(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(keep));
      y.erase(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(keep));
      const auto& own = e.at("axes")[0].at(name);  // the run's one axis
      for (const auto& v : own.at("t")) t.push_back(v.get<double>());
      for (const auto& v : own.at("y")) y.push_back(v.is_null() ? NAN : v.get<double>());
    }
  }
};

// A page sent only what changed holds what a fresh snapshot shows, column
// for column, and pays at most 64 KiB/s for it over a run's first 10 s and
// 32 KiB/s once the window is full, at the default rates, with the board's
// status, compressed as a browser reads it (before, each event was the
// whole window: about 1 MB/s; then the status's histograms alone were about
// 80 KB/s).
TEST(LiveFeed, APageSentWhatChangedShowsTheSnapshotsPictureForLittle) {
  LiveFeed feed(20.0, 0.3);
  PageWindow page;
  LiveCursor cursor;
  GzipStream gzip;
  std::size_t first_bytes = 0, steady_bytes = 0, first_json = 0, steady_json = 0;
  int resets = 0;
  for (int event = 0; event < 240; ++event) {  // 60 s, four events a second
    feed.add(rig_rows(event * 0.25, 0.25));
    feed.set_status(rig_status((event + 1) * 0.25));
    const auto e = feed.changes(cursor);
    resets += e.at("reset").get<bool>() ? 1 : 0;
    EXPECT_FALSE(e.at("status").at("board").at("drive").contains("histogram_us"))
        << "the histograms go apart from the status";
    // What goes on the wire to a browser: the event, gzip-compressed.
    const std::size_t json = e.dump().size(),
                      wire = gzip.compress("data: " + e.dump() + "\n\n").size();
    if (event < 40) first_bytes += wire, first_json += json;
    if (event >= 120) {
      EXPECT_FALSE(e.at("reset").get<bool>()) << "event " << event;
      steady_bytes += wire, steady_json += json;
    }
    page.apply(e);
    // The page's histograms are those of one of the last four events (at
    // most a second old).
    bool recent = false;
    for (int back = 0; back < 4 && back <= event && !recent; ++back) {
      const auto board = rig_status((event + 1 - back) * 0.25).at("board");
      recent = page.histograms.value("drive", nlohmann::json()) ==
                   board.at("drive").at("histogram_us") &&
               page.histograms.value("sensor", nlohmann::json()) ==
                   board.at("sensor").at("histogram_us");
    }
    EXPECT_TRUE(recent) << "event " << event;
  }
  EXPECT_LE(resets, 12) << "the window is sent again only as the columns widen";
  const double opening = static_cast<double>(first_bytes) / 10.0,
               steady = static_cast<double>(steady_bytes) / 30.0;
  EXPECT_LT(opening, 64 * 1024) << opening << " bytes/s over the first 10 s";
  EXPECT_LT(steady, 32 * 1024) << steady << " bytes/s once the window is full";
  std::cout << "a viewer costs " << opening / 1024 << " KiB/s over the first 10 s, "
            << steady / 1024 << " KiB/s once the window is full (" << resets
            << " windows sent whole); uncompressed " << static_cast<double>(first_json) / 10240.0
            << " and " << static_cast<double>(steady_json) / 30720.0 << " KiB/s\n";
  const auto snap = feed.snapshot();
  for (const char* name : {"drive", "measured", "observer", "open_loop", "residual"}) {
    const auto& st = snap.at("axes")[0].at(name).at("t");
    const auto& sy = snap.at("axes")[0].at(name).at("y");
    ASSERT_GT(st.size(), 1000u) << name;
    const auto& [pt, py] = page.series[name];
    const auto first =
        std::lower_bound(pt.begin(), pt.end(), st.front().get<double>()) - pt.begin();
    ASSERT_EQ(pt.size() - static_cast<std::size_t>(first), st.size()) << name;
    for (std::size_t i = 0; i < st.size(); ++i) {
      const auto j = static_cast<std::size_t>(first) + i;
      ASSERT_EQ(pt[j], st[i].get<double>()) << name << " point " << i;
      ASSERT_EQ(py[j], sy[i].get<double>()) << name << " point " << i;
    }
  }
}

// Each piece of a gzip stream decodes as it arrives (a browser shows an
// event when it comes, not when the stream ends).
TEST(GzipStream, EachPieceDecodesOnArrival) {
  GzipStream gzip;
  z_stream z{};
  ASSERT_EQ(inflateInit2(&z, 15 + 32), Z_OK);
  for (int i = 0; i < 50; ++i) {
    const std::string piece = "data: " + rig_status(i * 0.25).dump() + "\n\n";
    std::string in = gzip.compress(piece), out(piece.size() + 64, '\0');
    z.next_in = reinterpret_cast<Bytef*>(in.data());
    z.avail_in = static_cast<uInt>(in.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    const int rc = inflate(&z, Z_SYNC_FLUSH);
    ASSERT_TRUE(rc == Z_OK || rc == Z_BUF_ERROR) << rc;
    EXPECT_EQ(z.avail_in, 0u) << "piece " << i;
    out.erase(out.size() - z.avail_out);  // what inflate left unwritten
    ASSERT_EQ(out, piece) << "piece " << i;
    if (i > 0) {
      EXPECT_LT(in.size() * 3, piece.size()) << "piece " << i;
    }
  }
  inflateEnd(&z);
}

TEST(GzipStream, AcceptEncodingIsRead) {
  EXPECT_TRUE(accepts_gzip("gzip, deflate, br"));
  EXPECT_TRUE(accepts_gzip("deflate, GZip;q=0.5"));
  EXPECT_FALSE(accepts_gzip(""));
  EXPECT_FALSE(accepts_gzip("identity"));
  EXPECT_FALSE(accepts_gzip("gzip;q=0, deflate"));
  EXPECT_FALSE(accepts_gzip("gzipx"));
}

// A run that starts again (its clock back at zero) sends each page the new
// window whole.
TEST(LiveFeed, ANewRunSendsTheWindowAgain) {
  LiveFeed feed(20.0, 0.3);
  LiveCursor cursor;
  feed.add(rig_rows(0.0, 2.0));
  EXPECT_TRUE(feed.changes(cursor).at("reset").get<bool>());
  feed.add(rig_rows(2.0, 0.5));
  EXPECT_FALSE(feed.changes(cursor).at("reset").get<bool>());
  feed.add(rig_rows(0.0, 0.5));
  const auto e = feed.changes(cursor);
  EXPECT_TRUE(e.at("reset").get<bool>());
  EXPECT_LT(e.at("t_end").get<double>(), 0.6);
}

// A group move: each axis's series apart, under its name; an axis whose
// drive ended keeps its plot while the others' window moves on; what a
// page is sent as changes is what a snapshot shows.
TEST(LiveFeed, AGroupMoveShowsEachAxisApart) {
  LiveFeed feed(1.5, 0.3, 150);  // columns of 10 ms from the start
  feed.set_axes({"theta", "phi"});
  LiveCursor cursor;
  const auto scaled = [](log_schema::LogRows rows, double k) {
    for (double& v : rows.sensor.theta) v *= k;
    return rows;
  };
  feed.add(log_schema::AxesRows{rig_rows(0.0, 1.0), scaled(rig_rows(0.0, 1.0), -2.0)});
  const auto first = feed.changes(cursor);
  EXPECT_TRUE(first.at("reset").get<bool>());
  EXPECT_FALSE(first.contains("measured")) << "each axis's series go under axes";
  ASSERT_EQ(first.at("axes").size(), 2u);
  EXPECT_EQ(first.at("axes")[1].at("name"), "phi");
  // The board's frames hold a span of one axis's records, then the next
  // axis's for the same span: a batch may end between them, and the next
  // start with phi's records from before theta's last. The same run, not
  // a new one (the window is not started again).
  {
    log_schema::AxesRows split{rig_rows(1.0, 0.1), log_schema::LogRows{}};
    feed.add(split);
    log_schema::AxesRows rest{log_schema::LogRows{}, scaled(rig_rows(1.0, 0.1), -2.0)};
    feed.add(rest);
    EXPECT_FALSE(feed.changes(cursor).at("reset").get<bool>()) << "one span split across batches";
  }
  // theta's drive has ended; phi goes on for a second more.
  log_schema::LogRows theta_done;
  feed.add(log_schema::AxesRows{theta_done, scaled(rig_rows(1.1, 0.9), -2.0)});
  const auto later = feed.changes(cursor);
  EXPECT_FALSE(later.at("reset").get<bool>());
  EXPECT_NEAR(later.at("t_end").get<double>(), 1.9999, 1e-9);
  const auto& phi = later.at("axes")[1].at("measured").at("y");
  ASSERT_FALSE(phi.empty());
  EXPECT_LT(phi.back().get<double>(), 0.0) << "phi's own angle";
  EXPECT_TRUE(later.at("axes")[0].at("measured").at("y").empty()) << "nothing new for theta";
  const auto snap = feed.snapshot();
  EXPECT_GT(snap.at("axes")[0].at("measured").at("t").size(), 50u) << "theta's plot stays";
  EXPECT_GT(snap.at("axes")[0].at("zoom").at("y").size(), 2000u) << "its last periods";
}

TEST(LiveFeed, AScansTriggersArePointsOnItsAnglePlotEachSentOnce) {
  LiveFeed feed(1.5, 0.3, 150);  // columns of 10 ms
  LiveCursor cursor;
  // Pulses as the board streams them: each before the samples of its time.
  const auto add_pulse = [](log_schema::LogRows& rows, double edge_s, double angle_rad) {
    rows.triggers.k.push_back(static_cast<double>(rows.triggers.k.size()));
    rows.triggers.edge_s.push_back(edge_s);
    rows.triggers.angle_rad.push_back(angle_rad);
  };
  log_schema::LogRows first = rig_rows(0.0, 1.0);
  add_pulse(first, 0.25, 2e-3);
  feed.add(first);
  const auto sent = feed.changes(cursor).at("axes")[0].at("triggers");
  ASSERT_EQ(sent.at("t").size(), 1u) << "a pulse behind the drive's end is sent at once";
  EXPECT_NEAR(sent.at("t")[0].get<double>(), 0.25, 1e-9);
  EXPECT_NEAR(sent.at("y")[0].get<double>(), 2e-3, 1e-12);
  // The next pulse comes alone, once.
  log_schema::LogRows more = rig_rows(1.0, 0.2);
  add_pulse(more, 1.1, 3e-3);
  feed.add(more);
  const auto next = feed.changes(cursor);
  ASSERT_FALSE(next.at("reset").get<bool>());
  EXPECT_EQ(next.at("axes")[0].at("triggers").at("t").size(), 1u) << "only the new one, once";
  // One the stream lost, added from the summary at the end out of order: it
  // takes its place in time, and the page, whose copy of its column lacks
  // it, takes the window again.
  log_schema::LogRows summary;
  add_pulse(summary, 0.5, 2.5e-3);
  feed.add(summary);
  const auto again = feed.changes(cursor);
  EXPECT_TRUE(again.at("reset").get<bool>());
  const auto all = again.at("axes")[0].at("triggers").at("t");
  ASSERT_EQ(all.size(), 3u);
  EXPECT_TRUE(std::is_sorted(all.begin(), all.end()));
  EXPECT_EQ(feed.snapshot().at("axes")[0].at("triggers"), again.at("axes")[0].at("triggers"));
}

// A run's last moments: the pulse in the drive's last column, and that
// column itself, wait for later samples while the run goes on; once it has
// ended they go, with how it ended, and the run's owner learns when every
// open page has them.
TEST(LiveFeed, AnEndedRunSendsItsLastColumnsAndHowItEnded) {
  LiveFeed feed(1.5, 0.3, 150);  // columns of 10 ms
  LiveCursor cursor;
  log_schema::LogRows rows = rig_rows(0.0, 1.0);
  rows.triggers.k.push_back(0.0);
  rows.triggers.edge_s.push_back(0.9995);  // the drive's last column
  rows.triggers.angle_rad.push_back(1e-3);
  feed.add(rows);
  const auto running = feed.changes(cursor).at("axes")[0];
  EXPECT_TRUE(running.at("triggers").at("t").empty()) << "its column is not complete";
  const double drive_sent = running.at("drive").at("t").back().get<double>();
  EXPECT_LT(drive_sent, 0.99);
  const auto one_page = [] { return 1; };
  EXPECT_FALSE(feed.wait_until_pages_have_the_end(one_page, std::chrono::milliseconds(0)));

  feed.finish("completed");
  const auto ended = feed.changes(cursor);
  EXPECT_FALSE(feed.wait_until_pages_have_the_end(one_page, std::chrono::milliseconds(0)))
      << "the end is written once the page's stream asks for the next event";
  bool told = false;
  std::thread owner(
      [&] { told = feed.wait_until_pages_have_the_end(one_page, std::chrono::seconds(60)); });
  const auto after = feed.changes(cursor);
  owner.join();
  EXPECT_TRUE(told);
  EXPECT_EQ(ended.at("status").at("ended"), "completed");
  const auto axis = ended.at("axes")[0];
  ASSERT_EQ(axis.at("triggers").at("t").size(), 1u);
  EXPECT_NEAR(axis.at("triggers").at("t")[0].get<double>(), 0.9995, 1e-9);
  ASSERT_FALSE(axis.at("drive").at("t").empty());
  EXPECT_NEAR(axis.at("drive").at("t").back().get<double>(), 0.9999, 1e-9) << "the last sample";
  EXPECT_TRUE(after.at("axes")[0].at("triggers").at("t").empty()) << "sent once";
  EXPECT_TRUE(after.at("axes")[0].at("drive").at("t").empty());
  (void)feed.changes(cursor);
  EXPECT_FALSE(feed.wait_until_pages_have_the_end([] { return 2; }, std::chrono::milliseconds(0)))
      << "one page counted once";
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
