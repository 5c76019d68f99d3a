// catalogue.csv: one header, then a line per run in the order they ended,
// with the run directory's own name (also when given with a trailing slash).

#include "io/catalogue.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "../support/run_command.hpp"

namespace piezo::host {
namespace {

TEST(Catalogue, OneHeaderThenALinePerRun) {
  const auto dir = testing::fresh_temp_dir("catalogue");
  append_to_catalogue(
      dir / "r1", {"2026-11-26T01:00:00Z", "completed", "duration", "sim.toml", 4.8, 0.0709698});
  append_to_catalogue((dir / "r2").string() + "/", {"", "recovered", "unknown", "", 1.25, -0.5});
  std::ifstream in(dir / "catalogue.csv");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(),
            "run_dir,utc_start,status,stop_cause,config,t_end_s,theta_end_rad\n"
            "r1,2026-11-26T01:00:00Z,completed,duration,sim.toml,4.8,0.0709698\n"
            "r2,,recovered,unknown,,1.25,-0.5\n");
}

}  // namespace
}  // namespace piezo::host
