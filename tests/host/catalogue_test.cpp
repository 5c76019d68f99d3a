// catalogue.csv: one header, then a line per axis of each run in the order
// the runs ended, with the run directory's own name (also when given with a
// trailing slash); a catalogue of the earlier shape (no axis column) is
// brought to this one, its lines kept.

#include "io/catalogue.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "../support/run_command.hpp"

namespace piezo::host {
namespace {

std::string read(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Catalogue, OneHeaderThenALinePerAxisOfEachRun) {
  const auto dir = testing::fresh_temp_dir("catalogue");
  append_to_catalogue(
      dir / "r1",
      {"2026-11-26T01:00:00Z", "completed", "duration", "sim.toml", 4.8, {{"rotor", 0.0709698}}});
  append_to_catalogue((dir / "r2").string() + "/",
                      {"", "recovered", "unknown", "", 1.25, {{"theta", -0.5}, {"phi", 0.25}}});
  append_to_catalogue(dir / "r3", {"", "failed", "log_failed", "sim.toml", 0.0, {}});
  EXPECT_EQ(read(dir / "catalogue.csv"),
            "run_dir,utc_start,status,stop_cause,config,t_end_s,axis,angle_end_rad\n"
            "r1,2026-11-26T01:00:00Z,completed,duration,sim.toml,4.8,rotor,0.0709698\n"
            "r2,,recovered,unknown,,1.25,theta,-0.5\n"
            "r2,,recovered,unknown,,1.25,phi,0.25\n"
            "r3,,failed,log_failed,sim.toml,0,,\n");
}

TEST(Catalogue, OneOfTheEarlierShapeIsBroughtUpToDateKeepingItsRuns) {
  const auto dir = testing::fresh_temp_dir("catalogue-old");
  std::ofstream(dir / "catalogue.csv")
      << "run_dir,utc_start,status,stop_cause,config,t_end_s,theta_end_rad\n"
         "r1,2026-11-26T01:00:00Z,completed,duration,sim.toml,4.8,0.0709698\n";
  append_to_catalogue(dir / "r2", {"", "completed", "on_target", "", 0.5, {{"rotor", 0.01}}});
  EXPECT_EQ(read(dir / "catalogue.csv"),
            "run_dir,utc_start,status,stop_cause,config,t_end_s,axis,angle_end_rad\n"
            "r1,2026-11-26T01:00:00Z,completed,duration,sim.toml,4.8,,0.0709698\n"
            "r2,,completed,on_target,,0.5,rotor,0.01\n");
}

}  // namespace
}  // namespace piezo::host
