// The `piezo` binary as people and scripts use it: exit codes, JSON on
// stdout, named errors on stderr, written files readable by other tools.

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "../support/run_command.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

const std::string kPiezo = build_paths::piezo;
const std::string kConfigs = std::string(build_paths::source_dir) + "/configs";

TEST(SimulateCli, JsonHasAngleAndVelocity) {
  const auto r = run_command(kPiezo + " simulate --duration 0.5 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j.at("theta_end_rad").get<double>(), 0.0);
  EXPECT_NEAR(j.at("mean_velocity_rad_s").get<double>(), j.at("theta_end_rad").get<double>() / 0.5,
              1e-12);
}

// A long simulation says how far it is on stderr (once a second); stdout
// keeps only the result.
TEST(SimulateCli, ALongSimulationShowsProgress) {
  // Progress comes once a second: the longest simulation allowed, an hour,
  // takes about 3 s (900 s, which this took before, now ends within the
  // first second).
  const auto r = run_command(kPiezo + " simulate --duration 3600 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("simulate: t "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" of 3600 s ("), std::string::npos) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("duration_s"), 3600.0);
}

TEST(SimulateCli, ConfigAndSetCombine) {
  const auto base =
      run_command(kPiezo + " simulate --config " + kConfigs + "/paper.toml --duration 0.5 --json");
  const auto faster = run_command(kPiezo + " simulate --config " + kConfigs +
                                  "/paper.toml --set V0=88 --set f=12 --duration 0.5 --json");
  ASSERT_EQ(base.exit_code, 0) << base.err;
  ASSERT_EQ(faster.exit_code, 0) << faster.err;
  EXPECT_GT(nlohmann::json::parse(faster.out)["theta_end_rad"].get<double>(),
            nlohmann::json::parse(base.out)["theta_end_rad"].get<double>());
}

TEST(SimulateCli, ReverseReportsTheBackwardVelocity) {
  const auto r = run_command(kPiezo + " simulate --direction reverse --duration 1 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("direction"), "reverse");
  EXPECT_LT(j.at("mean_velocity_rad_s").get<double>(), 0.0);
  const auto bad = run_command(kPiezo + " simulate --direction sideways");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--direction: sideways"), std::string::npos) << bad.err;
}

TEST(SimulateCli, CoulombModelRuns) {
  const auto r = run_command(kPiezo + " simulate --model coulomb --duration 0.5 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["model"], "coulomb");
}

TEST(SimulateCli, CsvHasNamedColumns) {
  const auto dir = fresh_temp_dir("cli-csv");
  const auto path = (dir / "run.csv").string();
  const auto r = run_command(kPiezo + " simulate --duration 0.2 --dt 1e-3 --out " + path);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("t,V,", 0), 0u) << header;
  EXPECT_NE(header.find("theta"), std::string::npos);
  int rows = 0;
  for (std::string line; std::getline(in, line);) ++rows;
  EXPECT_EQ(rows, 201);
  std::filesystem::remove_all(dir);
}

TEST(SimulateCli, Hdf5IsReadableByH5py) {
  const auto dir = fresh_temp_dir("cli-h5");
  const auto path = (dir / "run.h5").string();
  ASSERT_EQ(run_command(kPiezo + " simulate --duration 0.2 --dt 1e-3 --out " + path).exit_code, 0);
  const auto r = run_command(
      "/usr/bin/python3 -c \"import h5py,json; f=h5py.File('" + path +
      "','r'); print(len(f['t']), f['theta'][-1] > 0, json.loads(f.attrs['parameters'])['V0'])\"");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "201 True 80.0\n");
  std::filesystem::remove_all(dir);
}

struct BadInvocation {
  const char* name;
  const char* args;
  const char* expected_in_stderr;
};

class SimulateBadInput : public ::testing::TestWithParam<BadInvocation> {};

TEST_P(SimulateBadInput, ExitsWithCode2AndNamesTheKey) {
  const auto r = run_command(kPiezo + " simulate " + GetParam().args);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(GetParam().expected_in_stderr), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

INSTANTIATE_TEST_SUITE_P(
    Cli, SimulateBadInput,
    ::testing::Values(BadInvocation{"UnknownSetKey", "--set sigma9=1", "sigma9"},
                      BadInvocation{"SetNotANumber", "--set M=heavy", "M: 'heavy' is not a number"},
                      BadInvocation{"SetNaN", "--set mu=nan", "mu: 'nan' is not finite"},
                      BadInvocation{"SetOutOfRange", "--set K=-5", "allowed range (0, 1e+12]"},
                      BadInvocation{"SetMissingValue", "--set K", "expected KEY=VALUE"},
                      BadInvocation{"RiseFractionAboveOne", "--set C_dr=1 --set e_dr=1.5", "C_dr"},
                      BadInvocation{"UnknownModel", "--model stribeck", "allowed: lugre, coulomb"},
                      BadInvocation{"BadOutSuffix", "--out run.txt", "--out"},
                      BadInvocation{"NegativeDuration", "--duration -1", "allowed: (0, 3600] s"},
                      BadInvocation{"EndlessDuration", "--duration 1e300", "allowed: (0, 3600] s"},
                      BadInvocation{"AbsurdFriction", "--set mu=1e308", "allowed range (0, 2]"},
                      BadInvocation{"UnwritableOut", "--out /proc/piezo-test.csv",
                                    "--out: /proc/piezo-test.csv: cannot be written"},
                      BadInvocation{"MissingConfig", "--config /nonexistent/x.toml", "--config"}),
    [](const auto& test_info) { return test_info.param.name; });

TEST(SimulateCli, BadConfigFileNamesFileAndKey) {
  const auto dir = fresh_temp_dir("cli-badcfg");
  const auto path = (dir / "bad.toml").string();
  write_file(path, "[model]\nsigma0 = -3\n");
  const auto r = run_command(kPiezo + " simulate --config " + path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("model.sigma0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(0, 1e+12]"), std::string::npos) << r.err;
  std::filesystem::remove_all(dir);
}

TEST(SensitivityCli, JsonRanksAndWritesPlots) {
  const auto dir = fresh_temp_dir("cli-sens");
  const auto r = run_command(kPiezo + " sensitivity --json --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["parameters"].size(), 4u);
  std::vector<std::string> names;
  for (const auto& p : j["parameters"]) {
    names.push_back(p["name"]);
    EXPECT_EQ(p["levels"].size(), 5u);
    EXPECT_EQ(p["mean_velocity_rad_s"].size(), 5u);
    EXPECT_TRUE(p["elasticity"].is_number());
  }
  EXPECT_EQ(names, (std::vector<std::string>{"V0", "f", "mu", "D"}));
  EXPECT_EQ(j["ranking"].size(), 4u);
  EXPECT_NE(r.err.find("20/20"), std::string::npos) << "progress on stderr";
  for (const char* f : {"angle_V0.png", "velocity_D.png", "comparison.png", "velocity_mu.csv"}) {
    EXPECT_TRUE(std::filesystem::file_size(dir / f) > 0) << f;
  }
  std::filesystem::remove_all(dir);
}

TEST(SensitivityCli, BadBaselineIsRejectedBeforeRunning) {
  const auto r = run_command(kPiezo + " sensitivity --set mu=-1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("mu"), std::string::npos);
  EXPECT_EQ(r.err.find("runs done"), std::string::npos);
}

// Global sensitivity on the motor: the Sobol' indices of four parameters
// varied at once, checked against OpenTURNS on the very same design and
// outputs, and the Morris screening ranking them in the same order.
TEST(SensitivityCli, SobolAgreesWithOpenTurnsAndMorrisRanksTheSame) {
  const auto dir = fresh_temp_dir("cli-sobol");
  const std::string common = " --params V0,f,mu,D --runtime 0.5 --seed 3 --json";
  const auto sobol = run_command(kPiezo + " sensitivity --method sobol --samples 256" + common +
                                 " --out " + (dir / "sobol").string());
  ASSERT_EQ(sobol.exit_code, 0) << sobol.err;
  const auto s = nlohmann::json::parse(sobol.out);
  EXPECT_EQ(s.at("runs"), 256 * 6);
  std::vector<std::string> sobol_order, morris_order;
  for (const auto& p : s.at("parameters")) {
    sobol_order.push_back(p.at("name"));
    EXPECT_LE(p.at("ST_interval").at(0).get<double>(), p.at("ST").get<double>());
    EXPECT_GE(p.at("ST_interval").at(1).get<double>(), p.at("ST").get<double>());
  }
  for (const char* file : {"sobol.csv", "design.csv", "sobol.png", "convergence.png"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / "sobol" / file)) << file;
  }
  const auto ot = run_command("/usr/bin/python3 " + std::string(build_paths::source_dir) +
                              "/tests/host/openturns_check.py " + (dir / "sobol").string());
  EXPECT_EQ(ot.exit_code, 0) << ot.out << ot.err;

  const auto morris = run_command(kPiezo + " sensitivity --method morris --samples 20" + common +
                                  " --out " + (dir / "morris").string());
  ASSERT_EQ(morris.exit_code, 0) << morris.err;
  const auto m = nlohmann::json::parse(morris.out);
  for (const auto& p : m.at("parameters")) morris_order.push_back(p.at("name"));
  EXPECT_EQ(morris_order, sobol_order);
  EXPECT_TRUE(std::filesystem::exists(dir / "morris" / "morris.png"));
  std::filesystem::remove_all(dir);
}

// Beyond one machine: the same study under mpirun on two ranks gives the
// very same numbers as one process (rank 0 gathers and writes).
TEST(SensitivityCli, TwoMpiRanksGiveTheSameResultAsOneProcess) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "MPI's own allocations are not the sanitizers' business: run in the ci build";
#endif
  if (run_command("command -v mpirun").exit_code != 0) GTEST_SKIP() << "mpirun not installed";
  const std::string study =
      " sensitivity --method sobol --params V0,f,mu,D --runtime 0.3 --samples 32 --json";
  const auto single = run_command(kPiezo + study);
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const auto ranks =
      run_command("mpirun -n 2 --oversubscribe --allow-run-as-root " + kPiezo + study);
  ASSERT_EQ(ranks.exit_code, 0) << ranks.err;
  EXPECT_NE(ranks.err.find("on rank 0 of 2"), std::string::npos) << ranks.err;
  EXPECT_EQ(ranks.out, single.out);
}

TEST(SensitivityCli, AnUnknownMethodOrParameterIsRefused) {
  auto r = run_command(kPiezo + " sensitivity --method anova");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--method: anova"), std::string::npos) << r.err;
  r = run_command(kPiezo + " sensitivity --method sobol --params V0,Q");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--params: Q"), std::string::npos) << r.err;
}

// The broader frequency range: both models side by side, a table and a
// plot, and the fall of stick-slip past the stator's useful range named.
TEST(SweepCli, FrequencySweepWritesBothModelsAndAPlot) {
  const auto dir = fresh_temp_dir("cli-sweep");
  const auto r = run_command(kPiezo + " sweep --param f --from 1 --to 2000 --points 8 --log " +
                             "--periods 10 --json --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.at("values").size(), 8u);
  for (const char* m : {"lugre", "coulomb"}) {
    const auto& v = j.at(m).at("mean_velocity_rad_s");
    ASSERT_EQ(v.size(), 8u) << m;
    EXPECT_LT(std::abs(v.at(0).get<double>()), 1e-5) << m << ": at 1 Hz both edges stick";
    EXPECT_FALSE(j.at(m).at("stops_working_at").is_null()) << m;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "sweep.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "sweep.csv"));
  std::filesystem::remove_all(dir);
}

// Two parameters: a map per model, one row per value of the first.
TEST(SweepCli, TwoParametersMakeAMap) {
  const auto dir = fresh_temp_dir("cli-map");
  const auto r = run_command(kPiezo + " sweep --param f --from 5 --to 50 --points 3 --param2 D " +
                             "--from2 0.6 --to2 0.9 --points2 2 --periods 6 --model lugre --json " +
                             "--out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto& v = j.at("lugre").at("mean_velocity_rad_s");
  ASSERT_EQ(v.size(), 3u);
  ASSERT_EQ(v.at(0).size(), 2u);
  EXPECT_GT(v.at(2).at(1).get<double>(), v.at(2).at(0).get<double>()) << "faster with larger D";
  EXPECT_TRUE(std::filesystem::exists(dir / "map.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "map_lugre.csv"));
  std::filesystem::remove_all(dir);
}

TEST(SweepCli, AnUnknownParameterIsRefused) {
  const auto r = run_command(kPiezo + " sweep --param fq --from 1 --to 10");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--param: fq"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace piezo::testing

namespace piezo::testing {
namespace {

// A command that opens no file and runs under no MPI launcher does not
// load HDF5 or Open MPI (their modules come when first needed: a third of
// the start-up); one that writes a log does. A model command does not load
// the rig's commands, nor ZeroMQ with them; the help lists every command,
// a command line naming one builds it alone, and a board's command runs
// from its module.
TEST(Cli, HeavyLibrariesLoadOnlyWhenACommandNeedsThem) {
  const auto loaded = [](const std::string& args) {
    return run_command("LD_DEBUG=files " + kPiezo + args + " >/dev/null").err;
  };
  for (const std::string args : {" --help", " simulate --duration 0.01 --json"}) {
    const std::string trace = loaded(args);
    ASSERT_NE(trace.find("libfmt"), std::string::npos) << "LD_DEBUG traced nothing: " << trace;
    EXPECT_EQ(trace.find("libhdf5"), std::string::npos) << args;
    EXPECT_EQ(trace.find("libmpi"), std::string::npos) << args;
  }
  for (const std::string args :
       {" --version", " simulate --duration 0.01 --json", " simulate --help", " sensitivity --help",
        " sweep --help", " report --help", " recover --help", " identify --help",
        " compare --help"}) {
    const std::string trace = loaded(args);
    EXPECT_EQ(trace.find("libpiezo_rig_commands.so"), std::string::npos) << args;
    EXPECT_EQ(trace.find("libzmq"), std::string::npos) << args;
  }
  const std::string trace = loaded(" --help");
  EXPECT_NE(trace.find("libpiezo_rig_commands.so"), std::string::npos);
  EXPECT_NE(trace.find("libzmq"), std::string::npos);
  const auto help = run_command(kPiezo + " --help");
  for (const char* command :
       {"simulate", "identify", "run", "scan", "calibrate", "rig-sim", "estop"})
    EXPECT_NE(help.out.find(std::string("\n  ") + command + " "), std::string::npos) << command;
  // A rig command line builds its own command alone, and a nested one too.
  const auto estop = run_command(kPiezo + " estop --help");
  EXPECT_EQ(estop.exit_code, 0) << estop.err;
  EXPECT_NE(estop.out.find("estop [OPTIONS]"), std::string::npos) << estop.out;
  const auto read = run_command(kPiezo + " sensor read --help");
  EXPECT_EQ(read.exit_code, 0) << read.err;
  EXPECT_NE(read.out.find("--count"), std::string::npos) << read.out;
  const auto status = run_command(kPiezo + " status --rig tcp://127.0.0.1:1 --json");
  EXPECT_EQ(status.exit_code, 1) << status.err;
  EXPECT_NE(status.out.find("\"code\":\"no_reply\""), std::string::npos) << status.out;
  const auto h5 = std::filesystem::temp_directory_path() / "piezo-cli-modules.h5";
  const std::string h5_trace = loaded(" simulate --duration 0.01 --out " + h5.string());
  EXPECT_NE(h5_trace.find("libpiezo_h5.so"), std::string::npos);
  EXPECT_NE(h5_trace.find("libhdf5"), std::string::npos);
  EXPECT_GT(std::filesystem::file_size(h5), 0u);
  std::filesystem::remove(h5);
}

// What a new user tries first: the version says where the build came from;
// a short range, not a 300-digit one, for a bad duration.
TEST(Cli, VersionNamesTheRevisionAndBuildType) {
  const auto r = run_command(kPiezo + " --version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("piezo 0."), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(git "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" build)"), std::string::npos) << r.out;
  const auto d = run_command(kPiezo + " simulate --duration -1");
  EXPECT_LT(d.err.size(), 300u) << d.err;
}

// `piezo sensor read` uses the sensor alone: a simulated drive beside a
// Modbus sensor is not its business (it fails on the missing sensor, not
// on the pairing).
TEST(Cli, SensorReadChecksOnlyTheSensorsSections) {
  const auto dir = fresh_temp_dir("sensor-only");
  const auto path = (dir / "rig.toml").string();
  write_file(path,
             "[drive]\nbackend = \"sim\"\n[sensor]\nbackend = \"modbus-tcp\"\n[sensor.modbus]\n"
             "host = \"127.0.0.1\"\nport = 1\nresponse_timeout_s = 0.05\n[run]\n");
  const auto r = run_command(kPiezo + " sensor read --config " + path + " --count 1");
  EXPECT_EQ(r.err.find("cannot go with"), std::string::npos) << r.err;
  std::filesystem::remove_all(dir);
}

// `piezo sensor read --axis` reads that axis's own sensor (phi's here sees
// its rotor from 75 mm, theta's from 70 mm); a name the config lacks, or
// none on a config of several, is refused listing its axes; a config of one
// needs none.
TEST(Cli, SensorReadReadsTheNamedAxissSensor) {
  const std::string three = " sensor read --config " + kConfigs +
                            "/three-axes.toml --set axes.phi.sensor.sim.target_distance_m=0.075 "
                            "--count 2 --json --axis ";
  const auto mean_mm = [](const CommandResult& r) {
    const auto j = nlohmann::json::parse(r.out);
    double sum = 0.0;
    for (const auto& reading : j.at("readings")) sum += reading.at("displacement_m").get<double>();
    return 1e3 * sum / static_cast<double>(j.at("readings").size());
  };
  const auto phi = run_command(kPiezo + three + "phi");
  ASSERT_EQ(phi.exit_code, 0) << phi.err;
  EXPECT_NEAR(mean_mm(phi), 75.0, 0.01);
  const auto theta = run_command(kPiezo + three + "theta");
  ASSERT_EQ(theta.exit_code, 0) << theta.err;
  EXPECT_NEAR(mean_mm(theta), 70.0, 0.01);
  const auto psi = run_command(kPiezo + three + "psi");
  EXPECT_EQ(psi.exit_code, 2);
  EXPECT_NE(psi.err.find("\"psi\" is not an axis"), std::string::npos) << psi.err;
  EXPECT_NE(psi.err.find("allowed: theta, phi, chi"), std::string::npos) << psi.err;
  const auto none =
      run_command(kPiezo + " sensor read --config " + kConfigs + "/three-axes.toml --count 1");
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("required"), std::string::npos) << none.err;
  const auto one =
      run_command(kPiezo + " sensor read --config " + kConfigs + "/sim.toml --count 1");
  EXPECT_EQ(one.exit_code, 0) << one.err;
  EXPECT_NE(one.out.find("axis rotor"), std::string::npos) << one.out;
}

}  // namespace
}  // namespace piezo::testing

namespace piezo::testing {
namespace {

// `piezo sensor list` names what the configured devices are before anything
// is driven; a DAQ card that is not there is named with its device file.
TEST(Cli, SensorListNamesTheConfiguredDevices) {
  const auto sim = run_command(kPiezo + " sensor list --config " + kConfigs + "/sim.toml");
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  EXPECT_NE(sim.out.find("drive (sim): simulated"), std::string::npos) << sim.out;
  const auto card = run_command(kPiezo + " sensor list --config " + kConfigs +
                                "/daq.toml --set drive.comedi.device=/dev/no-such-card");
  EXPECT_EQ(card.exit_code, 1);
  EXPECT_NE(card.err.find("comedi /dev/no-such-card: cannot open"), std::string::npos) << card.err;
}

}  // namespace
}  // namespace piezo::testing
