// `piezo move --to AXIS=RAD ...` on a board of three simulated axes, as a
// user runs it: one group move, its log read by h5py axis by axis, each
// axis read back by `piezo report --axis` and `piezo identify --axis`, and
// bad groups refused before anything moves.

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "../support/run_command.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

namespace fs = std::filesystem;
const std::string kPiezo = build_paths::piezo;
const std::string kThreeAxes = std::string(build_paths::source_dir) + "/configs/three-axes.toml";

TEST(GroupMoveCli, MovesThreeAxesAndLogsEachUnderItsOwnGroup) {
  const auto dir = fresh_temp_dir("group-move");
  const auto out = dir / "group";
  const auto r =
      run_command(kPiezo + " move --config " + kThreeAxes +
                  " --to theta=0.01 --to phi=-0.02 --to chi=0.005 --json --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.at("moves").size(), 3u);
  const std::map<std::string, double> targets{{"theta", 0.01}, {"phi", -0.02}, {"chi", 0.005}};
  for (const auto& m : j.at("moves")) {
    const std::string axis = m.at("axis");
    EXPECT_TRUE(m.at("on_target").get<bool>()) << axis;
    EXPECT_NEAR(m.at("position_rad").get<double>(), targets.at(axis),
                m.at("tolerance_rad").get<double>())
        << axis;
  }
  // The run's own summary lists each axis, in the board's order.
  ASSERT_EQ(j.at("run").at("axes").size(), 3u);
  EXPECT_EQ(j.at("run").at("axes")[1].at("name"), "phi");
  EXPECT_EQ(j.at("run").at("axes")[1].at("stop_cause"), "on_target");

  // h5py: one group per axis, each with its own drive, sensor and summary;
  // each axis's logged angle ends at its own target.
  const auto check = run_command(
      "/usr/bin/python3 -c \"import h5py, json; f = h5py.File('" + (out / "run.h5").string() +
      "'); print(f.attrs['axes'].decode(), 'drive' in f); "
      "[print(a, round(f['axes/' + a + '/sensor/theta'][-1], 3), "
      "json.loads(f['axes/' + a].attrs['summary'])['move']['stop_cause'], "
      "len(f['axes/' + a + '/drive/t']) == len(f['axes/' + a + '/drive/V']) > 1000) "
      "for a in ('theta', 'phi', 'chi')]\"");
  EXPECT_EQ(check.out,
            "theta,phi,chi False\ntheta 0.01 on_target True\nphi -0.02 on_target True\n"
            "chi 0.005 on_target True\n")
      << check.err;

  // Each axis read back on its own; the log's axes named when none is given.
  const auto report = run_command(kPiezo + " report " + out.string() + " --axis phi --json");
  ASSERT_EQ(report.exit_code, 0) << report.err;
  EXPECT_TRUE(fs::exists(out / "report-phi" / "angle.png"));
  const auto identify = run_command(kPiezo + " identify --log " + (out / "run.h5").string() +
                                    " --axis chi --params d_e --json");
  EXPECT_EQ(identify.exit_code, 0) << identify.err;
  const auto none = run_command(kPiezo + " report " + out.string());
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("--axis: required: the log holds several axes (theta, phi, chi)"),
            std::string::npos)
      << none.err;
  const auto unknown = run_command(kPiezo + " report " + out.string() + " --axis psi");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("\"psi\" is not an axis of the log"), std::string::npos)
      << unknown.err;
  fs::remove_all(dir);
}

TEST(GroupMoveCli, ABadGroupIsRefusedByNameAndNothingIsCreated) {
  const auto dir = fresh_temp_dir("group-move-bad");
  struct Bad {
    std::string args, says;
  };
  for (const Bad& bad : {
           Bad{"--to theta=0.01 --to psi=0.02",
               "targets.psi: \"psi\" is not an axis of the board "
               "(allowed: theta, phi, chi)"},
           Bad{"--to theta=0.01 --to theta=0.02", "names its axis twice"},
           Bad{"--to theta=0.01 --to 0.02", "a group move gives AXIS=RAD for each axis"},
           Bad{"--to theta=abc", "a group move gives AXIS=RAD for each axis"},
           Bad{"--to theta=0.01 --to phi=11", "targets.phi"},
           Bad{"--to theta=0.01 --to chi=0.6",
               "targets.chi: 0.6 rad is outside axis chi's travel window [-0.5, 0.5] rad"},
           Bad{"--to 0.6 --axis chi", "target_rad: 0.6 rad is outside axis chi's travel window"},
           Bad{"--to theta=0.01 --axis phi", "a group move names its axes in --to"},
           Bad{"--to 0.01", "rig.axis: required: the board has several axes"},
       }) {
    const auto r = run_command(kPiezo + " move --config " + kThreeAxes + " " + bad.args +
                               " --out " + (dir / "bad").string());
    EXPECT_EQ(r.exit_code, 2) << bad.args << ": " << r.err;
    EXPECT_NE(r.err.find(bad.says), std::string::npos) << bad.args << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "bad")) << bad.args;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace piezo::testing
