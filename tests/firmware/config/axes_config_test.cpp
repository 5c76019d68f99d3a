// A board's axes in its config: [axes.NAME] overlays the file's sections
// for that axis; a config without [axes] is one axis, as before. Each
// refusal names the key, the file and what is allowed.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "../../support/run_command.hpp"
#include "build_paths.hpp"
#include "config/config_file.hpp"
#include "config/effective_config.hpp"
#include "config/rig.hpp"
#include "piezo/config/config_error.hpp"

namespace piezo::config {
namespace {

using piezo::testing::fresh_temp_dir;
using piezo::testing::write_file;

const std::string kBoard = R"(
[drive]
backend = "sim"
[sensor]
backend = "sim"
[lines]
backend = "sim"
[run]
clock = "virtual"
)";

class AxesConfig : public ::testing::Test {
 protected:
  std::filesystem::path dir = fresh_temp_dir("axes-config");
  std::string file(const std::string& text) {
    const auto path = dir / "board.toml";
    write_file(path, text);
    return path.string();
  }
  /// The refusal's text (empty: none).
  std::string refusal(const std::string& text, const std::vector<std::string>& sets = {}) {
    try {
      (void)load_config_file(file(text), sets);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return {};
  }
  void TearDown() override { std::filesystem::remove_all(dir); }
};

TEST_F(AxesConfig, AConfigWithoutAxesIsOneAxisNamedRotor) {
  const BoardConfig board = load_config_file(file(kBoard)).board;
  ASSERT_EQ(board.axes.size(), 1u);
  EXPECT_EQ(board.axis().name, "rotor");
  EXPECT_FALSE(board.fault_stops_all);
}

TEST_F(AxesConfig, TheThreeAxisBoardOverlaysEachAxisOnTheFilesSections) {
  const BoardConfig board =
      load_config_file(std::string(build_paths::source_dir) + "/configs/three-axes.toml").board;
  ASSERT_EQ(board.axes.size(), 3u);
  EXPECT_EQ(board.axes[0].name, "theta");
  EXPECT_EQ(board.axes[1].name, "phi");
  EXPECT_EQ(board.axes[2].name, "chi");
  // Each axis's own keys; the rest is the file's.
  EXPECT_EQ(board.axes[1].plant.J, 3.0e-6);
  EXPECT_EQ(board.axes[1].sensor.r2_m, 0.08);
  EXPECT_EQ(board.axes[0].sensor.r2_m, 0.062);
  EXPECT_EQ(board.axes[0].plant.J, board.axes[2].plant.J);
  EXPECT_EQ(board.axes[2].drive.limits.V_max, 60.0);
  EXPECT_EQ(board.axes[2].model.drive.V0, 60.0);
  EXPECT_EQ(board.axes[0].drive.limits.V_max, 80.0);
  EXPECT_EQ(board.axes[2].safety.travel_max_rad, 0.5);
  EXPECT_TRUE(std::isinf(board.axes[0].safety.travel_max_rad));
  EXPECT_EQ(board.drive_rate_hz, 10'000.0) << "the board's, not an axis's";
  for (const AxisConfig& a : board.axes) {
    EXPECT_EQ(a.plant_coupling, 0.02) << a.name << ": crosstalk on";
  }
}

// The run's written-back config holds every axis, from the readers' own
// declarations: loaded again, it is the same board, axis for axis.
TEST_F(AxesConfig, TheEffectiveConfigHoldsEveryAxisAndLoadsAsTheSameBoard) {
  const ConfigFile three =
      load_config_file(std::string(build_paths::source_dir) + "/configs/three-axes.toml");
  const std::string effective = effective_config_toml(three);
  for (const char* section : {"[axes.theta.drive]", "[axes.phi.sensor]", "[axes.chi.safety]",
                              "[axes.phi.plant]", "[lines]", "[piezod]"}) {
    EXPECT_NE(effective.find(section), std::string::npos) << section << "\n" << effective;
  }
  EXPECT_EQ(effective.find("[drive.modbus"), std::string::npos) << "the chosen backend's alone";
  const BoardConfig again = load_config_file(file(effective)).board;
  ASSERT_EQ(again.axes.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const AxisConfig &a = again.axes[i], &b = three.board.axes[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.sensor.r2_m, b.sensor.r2_m) << a.name;
    EXPECT_EQ(a.plant.J, b.plant.J) << a.name;
    EXPECT_EQ(a.drive.limits.V_max, b.drive.limits.V_max) << a.name;
    EXPECT_EQ(a.model.drive.V0, b.model.drive.V0) << a.name;
    EXPECT_EQ(a.safety.travel_max_rad, b.safety.travel_max_rad) << a.name;
    EXPECT_EQ(a.plant_coupling, b.plant_coupling) << a.name;
  }
  // A board of one: the same, with its one axis.
  const ConfigFile one = load_config_file(file(kBoard), {"sensor.r2_m=0.05"});
  const ConfigFile one_again = load_config_file(file(effective_config_toml(one)));
  ASSERT_EQ(one_again.board.axes.size(), 1u);
  EXPECT_EQ(one_again.board.axis().name, "rotor");
  EXPECT_EQ(one_again.board.axis().sensor.r2_m, 0.05);
  EXPECT_EQ(one_again.host.model.motor.F_N, one.host.model.motor.F_N);
}

TEST_F(AxesConfig, SetReachesOneAxis) {
  const BoardConfig board = load_config_file(file(kBoard + "[axes.a]\n[axes.b]\n"),
                                             {"axes.b.drive.V_max=50", "axes.b.drive.V0=40"})
                                .board;
  EXPECT_EQ(board.axes[0].drive.limits.V_max, 80.0);
  EXPECT_EQ(board.axes[1].drive.limits.V_max, 50.0);
}

TEST_F(AxesConfig, TheSimulatedRigHasAPlantPerAxisOnOneEnable) {
  const BoardConfig board =
      load_config_file(std::string(build_paths::source_dir) + "/configs/three-axes.toml").board;
  const Rig rig = build_rig(board);
  ASSERT_EQ(rig.axes.size(), 3u);
  ASSERT_TRUE(rig.sim);
  EXPECT_EQ(rig.sim->axis_count(), 3u);
  EXPECT_NE(rig.axes[0].drive, rig.axes[1].drive);
  EXPECT_EQ(rig.axes[2].drive->limits().V_max, 100.0) << "the DAC's reach, whatever the axis asks";
  EXPECT_EQ(rig.sim->plant(1).latest().theta, 0.0);
}

TEST_F(AxesConfig, AnAxisNamedTwiceIsRefused) {
  const std::string e = refusal(kBoard + "[axes.a]\n[axes.a]\n");
  EXPECT_NE(e.find("axes.a"), std::string::npos) << e;
}

/// Two axes on one Modbus link: the analog-output module's register 3 and
/// the sensor's register (its default) for both, until an axis says otherwise.
const std::string kModbusAxes = R"(
[drive]
backend = "modbus-ao"
[drive.modbus-ao]
host = "127.0.0.1"
address = 3
link_loss_acknowledged = true
[sensor]
backend = "modbus-tcp"
[sensor.modbus]
host = "127.0.0.1"
[lines]
backend = "none"
[run]
[axes.theta]
[axes.phi]
)";

TEST_F(AxesConfig, TwoAxesOnOneOutputAreRefusedNamingBoth) {
  const std::string sensors_apart = "[axes.phi.sensor.modbus]\nunit_id = 2\n";
  const std::string e = refusal(kModbusAxes + sensors_apart);
  EXPECT_NE(e.find("drive.modbus-ao.address (axis phi)"), std::string::npos) << e;
  EXPECT_NE(e.find("theta"), std::string::npos) << e;
  EXPECT_NE(e.find("register 3"), std::string::npos) << e;
  // Each its own register: accepted.
  EXPECT_EQ(refusal(kModbusAxes + sensors_apart + "[axes.phi.drive.modbus-ao]\naddress = 4\n"), "");
}

TEST_F(AxesConfig, TwoAxesOnOneInputAreRefused) {
  const std::string e = refusal(kModbusAxes + "[axes.phi.drive.modbus-ao]\naddress = 9\n");
  EXPECT_NE(e.find("sensor.modbus.address (axis phi)"), std::string::npos) << e;
}

// A reading of two words (f32) takes both registers: a sensor whose first
// register is the other's second overlaps it; one past it does not.
TEST_F(AxesConfig, TwoInputsThatOverlapAreRefused) {
  const std::string outputs_apart =
      "[axes.phi.drive.modbus-ao]\naddress = 9\n[axes.theta.sensor.modbus]\ntype = \"f32\"\n"
      "address = 0\n";
  const std::string e =
      refusal(kModbusAxes + outputs_apart + "[axes.phi.sensor.modbus]\naddress = 1\n");
  EXPECT_NE(e.find("input register 1 is also axes.theta.sensor.modbus.address's"),
            std::string::npos)
      << e;
  EXPECT_EQ(refusal(kModbusAxes + outputs_apart + "[axes.phi.sensor.modbus]\naddress = 2\n"), "");
}

TEST_F(AxesConfig, AKeyOfAnAxisIsNamedUnderItsAxis) {
  EXPECT_NE(refusal(kBoard + "[axes.phi.drive]\nV_mx = 3\n").find("axes.phi.drive.V_mx"),
            std::string::npos);
  const std::string range = refusal(kBoard + "[axes.phi.drive]\nV_max = 3000\n");
  EXPECT_NE(range.find("axes.phi.drive.V_max"), std::string::npos) << range;
  EXPECT_NE(range.find("board.toml"), std::string::npos) << range;
}

TEST_F(AxesConfig, TheBoardsOwnSectionsAreNotAnAxiss) {
  const std::string lines = refusal(kBoard + "[axes.phi.lines]\nbackend = \"none\"\n");
  EXPECT_NE(lines.find("axes.phi.lines"), std::string::npos) << lines;
  EXPECT_NE(lines.find("allowed"), std::string::npos) << lines;
  const std::string rate = refusal(kBoard + "[axes.a]\n[axes.b.drive]\nrate_hz = 5000\n");
  EXPECT_NE(rate.find("axes.b.drive.rate_hz"), std::string::npos) << rate;
  EXPECT_NE(rate.find("one tick"), std::string::npos) << rate;
  EXPECT_NE(rate.find("allowed: drive.rate_hz alone"), std::string::npos) << rate;
  const std::string sensor_rate = refusal(kBoard + "[axes.a]\n[axes.b.sensor]\nrate_hz = 500\n");
  EXPECT_NE(sensor_rate.find("axes.b.sensor.rate_hz"), std::string::npos) << sensor_rate;
  EXPECT_NE(refusal(kBoard + "[axes.a.safety]\nfault_stops_all = true\n")
                .find("axes.a.safety.fault_stops_all"),
            std::string::npos);
}

TEST_F(AxesConfig, AnAxisNameACommandLineCannotCarryIsRefused) {
  const std::string e = refusal(kBoard + "[axes.\"a b\"]\n");
  EXPECT_NE(e.find("axes.a b"), std::string::npos) << e;
  EXPECT_NE(refusal(kBoard + "[axes]\nphi = 3\n").find("axes.phi"), std::string::npos);
}

TEST_F(AxesConfig, AValueBadForOneAxisNamesThatAxis) {
  // [drive] V_max is fine for theta; chi's own V_min is above it.
  const std::string e = refusal(kBoard + "[axes.theta]\n[axes.chi.drive]\nV_min = 79\nV0 = 80\n");
  EXPECT_NE(e.find("axes.chi.drive"), std::string::npos) << e;
}

}  // namespace
}  // namespace piezo::config
