// Logs written before every axis was kept under /axes/NAME (their one axis
// at the root; tests/data/logs-before-axes: a completed run and a run
// killed mid-way, its journal beside it) still open, report, identify,
// compare and recover, as a user with last year's runs would ask.

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "../support/run_command.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

namespace fs = std::filesystem;
const std::string kPiezo = build_paths::piezo;
const fs::path kOldLogs = fs::path(build_paths::source_dir) / "tests/data/logs-before-axes";

/// A copy of the old logs, so that recovery and reports write beside them.
fs::path copy_of_old_logs(const std::string& tag) {
  const fs::path dir = fresh_temp_dir(tag);
  fs::copy(kOldLogs, dir, fs::copy_options::recursive);
  return dir;
}

TEST(OldLogs, ACompletedRunReportsIdentifiesAndComparesAsBefore) {
  const fs::path dir = copy_of_old_logs("old-completed");
  const std::string log = (dir / "completed" / "run.h5").string();
  const auto report = run_command(kPiezo + " report " + (dir / "completed").string() +
                                  " --json --out " + (dir / "report").string());
  ASSERT_EQ(report.exit_code, 0) << report.err;
  EXPECT_GT(nlohmann::json::parse(report.out).dump().size(), 10u);
  const auto compare = run_command(kPiezo + " compare --log " + log + " --json");
  ASSERT_EQ(compare.exit_code, 0) << compare.err;
  const auto identify =
      run_command(kPiezo + " identify --log " + log + " --params F_N --max-iterations 3 --json");
  ASSERT_EQ(identify.exit_code, 0) << identify.err;
  // Its one axis is its own: naming another is refused, naming none is not needed.
  const auto other = run_command(kPiezo + " identify --log " + log + " --axis phi --params F_N");
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_NE(other.err.find("the log holds one axis"), std::string::npos) << other.err;
}

TEST(OldLogs, AKilledRunRecoversAndThenReports) {
  const fs::path dir = copy_of_old_logs("old-killed");
  const auto recovered = run_command(kPiezo + " recover " + (dir / "killed").string() + " --json");
  ASSERT_EQ(recovered.exit_code, 0) << recovered.out << recovered.err;
  const auto j = nlohmann::json::parse(recovered.out);
  EXPECT_EQ(j.at("status"), "recovered") << j.dump();
  // Kept where it was: at the root, every row the journal held.
  const auto rows = run_command(
      "/usr/bin/python3 -c \"import h5py; f = h5py.File('" + (dir / "killed" / "run.h5").string() +
      "'); print(f.attrs['status'].decode(), 'axes' in f, len(f['drive/t']) > 1000)\"");
  EXPECT_EQ(rows.out, "recovered False True\n") << rows.err;
  const auto report = run_command(kPiezo + " report " + (dir / "killed").string() +
                                  " --json --out " + (dir / "report").string());
  EXPECT_EQ(report.exit_code, 0) << report.err;
}

}  // namespace
}  // namespace piezo::testing
