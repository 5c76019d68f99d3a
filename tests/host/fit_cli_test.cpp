// `piezo identify` and `piezo compare` on a CSV written by the test from a
// known motor, and their outputs fed back into simulate and run.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "../support/run_command.hpp"
#include "build_paths.hpp"
#include "piezo/model/identify.hpp"

namespace piezo::testing {
namespace {

namespace fs = std::filesystem;
const std::string kPiezo = build_paths::piezo;

/// t, V, theta at 500 Hz from a LuGre motor with known parameters, 8 urad noise.
fs::path write_synthetic_csv(const fs::path& dir, const model::Parameters& truth) {
  model::FitData d;
  const model::Sawtooth saw(truth.drive.V0, truth.drive.f, truth.drive.D());
  d.t = model::uniform_times(0.8, 2e-3);
  for (double t : d.t) {
    d.drive_t.push_back(t);
    d.drive_V.push_back(saw.voltage(t));
  }
  d.ramp_time = 2e-3;
  const auto theta = model::predict(truth, d, model::FrictionModel::lugre);
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 8e-6);
  const fs::path path = dir / "measured.csv";
  std::ofstream out(path);
  out << "t,V,theta\n";
  out.precision(12);
  for (std::size_t i = 0; i < d.t.size(); ++i) {
    out << d.t[i] << "," << d.drive_V[i] << "," << theta[i] + noise(rng) << "\n";
  }
  return path;
}

model::Parameters truth() {
  model::Parameters p;
  p.motor.sigma0 = 2100;
  p.motor.F_N = 5.4e-3;
  p.motor.d_e = 0.5e-6;
  return p;
}

TEST(IdentifyCli, FitsACsvAndTheResultFeedsSimulate) {
  const auto dir = fresh_temp_dir("identify-cli");
  const auto csv = write_synthetic_csv(dir, truth());
  const auto fitted = dir / "fitted.toml";
  const auto r = run_command(kPiezo + " identify --log " + csv.string() +
                             " --params sigma0,F_N,d_e --json --out " + fitted.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("identify: iteration 1,"), std::string::npos) << "progress on stderr";
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_LT(j.at("rmse_rad").get<double>(), 10e-6);
  for (const char* name : {"sigma0", "F_N", "d_e"}) {
    const double value = j.at("parameters").at(name);
    const double lo = j.at("confidence_95").at(name)[0], hi = j.at("confidence_95").at(name)[1];
    const double true_value = *model::get_parameter(truth(), name);
    EXPECT_LE(lo, true_value) << name << " = " << value;
    EXPECT_GE(hi, true_value) << name << " = " << value;
  }
  const auto sim =
      run_command(kPiezo + " simulate --config " + fitted.string() + " --duration 0.2 --json");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  EXPECT_NEAR(nlohmann::json::parse(sim.out).at("parameters").at("sigma0").get<double>(),
              j.at("parameters").at("sigma0").get<double>(), 1e-6);
}

// Logs from other tools: the same measurement as a MATLAB v7.3 .mat (HDF5
// behind a 512-byte user block, column vectors stored 1 x N, MATLAB_class
// attributes) and as a plain HDF5 file with names of its own, both written
// by h5py; identify reads each through --t/--V/--theta and fits it as the
// CSV. A dataset that is not there is named, exit 2.
TEST(IdentifyCli, ReadsMatlabAndForeignHdf5FilesByDatasetPath) {
  const auto dir = fresh_temp_dir("identify-foreign");
  const auto csv = write_synthetic_csv(dir, truth());
  const auto mat = dir / "measured.mat", h5 = dir / "foreign.h5";
  const auto written = run_command(
      "/usr/bin/python3 -c \"import h5py, numpy as np; d = np.genfromtxt('" + csv.string() +
      "', delimiter=',', names=True)\n"
      "with h5py.File('" +
      mat.string() +
      "', 'w', userblock_size=512) as f:\n"
      "    for k in ('t', 'V', 'theta'):\n"
      "        ds = f.create_dataset(k, data=d[k].reshape(1, -1)); "
      "ds.attrs['MATLAB_class'] = np.bytes_('double')\n"
      "with h5py.File('" +
      h5.string() +
      "', 'w') as f:\n"
      "    f['rig/time'] = d['t']; f['rig/drive'] = d['V']; f['rig/angle'] = d['theta']\"");
  ASSERT_EQ(written.exit_code, 0) << written.err;
  for (const auto& [file, layout] :
       {std::pair{mat, std::string(" --t /t --V /V --theta /theta")},
        std::pair{h5, std::string(" --t /rig/time --V /rig/drive --theta /rig/angle")}}) {
    const auto r = run_command(kPiezo + " identify --log " + file.string() + layout +
                               " --params sigma0,F_N,d_e --json");
    ASSERT_EQ(r.exit_code, 0) << file << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_LT(j.at("rmse_rad").get<double>(), 10e-6) << file;
    EXPECT_NEAR(j.at("parameters").at("d_e").get<double>(), truth().motor.d_e,
                0.05 * truth().motor.d_e)
        << file;
  }
  const auto missing = run_command(kPiezo + " identify --log " + h5.string() +
                                   " --t /rig/time --V /rig/volts --theta /rig/angle");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("/rig/volts: no such dataset (--V)"), std::string::npos)
      << missing.err;
  const auto unnamed = run_command(kPiezo + " identify --log " + h5.string());
  EXPECT_EQ(unnamed.exit_code, 2);
  EXPECT_NE(unnamed.err.find("name its datasets (--t, --V, --theta, --theta-t)"), std::string::npos)
      << unnamed.err;
}

// report reads other tools' logs as identify does: the measurement as a
// MATLAB-style file by dataset path, and as a CSV, with the model's
// parameters from --config (the file carries none). The model then follows
// the measurement to the noise; Table 1 (no --config) does not.
TEST(ReportCli, PlotsAnotherToolsFileWithTheParametersOfAConfig) {
  const auto dir = fresh_temp_dir("report-foreign");
  const auto csv = write_synthetic_csv(dir, truth());
  const auto mat = dir / "measured.mat";
  const auto written = run_command(
      "/usr/bin/python3 -c \"import h5py, numpy as np; d = np.genfromtxt('" + csv.string() +
      "', delimiter=',', names=True)\n"
      "with h5py.File('" +
      mat.string() +
      "', 'w', userblock_size=512) as f:\n"
      "    for k, n in (('t', 'time'), ('V', 'volts'), ('theta', 'angle')):\n"
      "        ds = f.create_dataset(n, data=d[k].reshape(-1, 1)); "
      "ds.attrs['MATLAB_class'] = np.bytes_('double')\"");
  ASSERT_EQ(written.exit_code, 0) << written.err;
  const auto config = dir / "truth.toml";
  write_file(config, "[model]\nsigma0 = 2100\nF_N = 5.4e-3\nd_e = 0.5e-6\n");
  const auto matlab =
      run_command(kPiezo + " report " + mat.string() +
                  " --t /time --V /volts --theta /angle --json --config " + config.string());
  ASSERT_EQ(matlab.exit_code, 0) << matlab.err;
  const auto j = nlohmann::json::parse(matlab.out);
  EXPECT_LT(j.at("rmse_model_rad").get<double>(), 10e-6);
  EXPECT_EQ(j.at("status"), "external log");
  EXPECT_TRUE(fs::exists(dir / "measured-report" / "angle.png"));
  const auto from_csv =
      run_command(kPiezo + " report " + csv.string() + " --json --config " + config.string());
  ASSERT_EQ(from_csv.exit_code, 0) << from_csv.err;
  EXPECT_NEAR(nlohmann::json::parse(from_csv.out).at("rmse_model_rad").get<double>(),
              j.at("rmse_model_rad").get<double>(), 1e-9);
  const auto table1 = run_command(kPiezo + " report " + csv.string() + " --json");
  ASSERT_EQ(table1.exit_code, 0) << table1.err;
  EXPECT_GT(nlohmann::json::parse(table1.out).at("rmse_model_rad").get<double>(), 20e-6);
  const auto unnamed = run_command(kPiezo + " report " + mat.string());
  EXPECT_EQ(unnamed.exit_code, 2);
  EXPECT_NE(unnamed.err.find("name its datasets"), std::string::npos) << unnamed.err;
}

TEST(IdentifyCli, NotesWhenMuAndNormalForceAreBothFree) {
  const auto dir = fresh_temp_dir("identify-notes");
  const auto csv = write_synthetic_csv(dir, model::Parameters{});
  const auto r =
      run_command(kPiezo + " identify --log " + csv.string() + " --params mu,F_N --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto notes = nlohmann::json::parse(r.out).at("notes");
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes[0].get<std::string>().find("only as their product"), std::string::npos);
}

TEST(IdentifyCli, BadInputIsNamed) {
  const auto dir = fresh_temp_dir("identify-bad");
  const auto csv = write_synthetic_csv(dir, model::Parameters{});
  auto r = run_command(kPiezo + " identify --log " + csv.string() + " --params sigma9");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--params: sigma9: unknown parameter"), std::string::npos) << r.err;
  const auto bad_csv = dir / "bad.csv";
  write_file(bad_csv, "t,V\n0,1\n");
  r = run_command(kPiezo + " identify --log " + bad_csv.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("theta: missing column"), std::string::npos) << r.err;
}

TEST(CompareCli, RanksLuGreAheadOnLuGreData) {
  const auto dir = fresh_temp_dir("compare-cli");
  const auto csv = write_synthetic_csv(dir, truth());
  const auto r = run_command(kPiezo + " compare --log " + csv.string() + " --json --out " +
                             (dir / "plots").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const double lugre = j.at("lugre").at("rmse_rad"), coulomb = j.at("coulomb").at("rmse_rad");
  EXPECT_LT(lugre, coulomb);
  EXPECT_NEAR(j.at("improvement").get<double>(), coulomb / lugre, 1e-9);
  EXPECT_GT(j.at("improvement").get<double>(), 2.0);
  EXPECT_TRUE(j.at("lugre").at("parameters").contains("sigma0"));
  EXPECT_TRUE(j.at("coulomb").at("parameters").contains("F_N"));
  EXPECT_GT(fs::file_size(dir / "plots" / "compare.png"), 1000u);
}

// A real-time log of configs/sim.toml (4.8 s; drive and angle kept, the
// rest left out) on which the Coulomb fit visits parameters whose contact
// chatters between stick and slip at a grazing point (a Zeno sequence):
// the closed-form integrator stopped there ("switches endlessly"). It takes
// the chatter's limit, sticking, and Table III's comparison completes.
TEST(CompareCli, ChatteringContactIsStickingNotAnError) {
  const std::string log =
      std::string(build_paths::source_dir) + "/tests/data/chattering_contact.h5";
  const auto r = run_command(kPiezo + " compare --log " + log + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const double lugre = j.at("lugre").at("rmse_rad"), coulomb = j.at("coulomb").at("rmse_rad");
  EXPECT_TRUE(std::isfinite(coulomb));
  EXPECT_LT(lugre, coulomb);
  EXPECT_LT(coulomb, 1e-3) << "the Coulomb fit follows the log to within a milliradian";
}

}  // namespace
}  // namespace piezo::testing
