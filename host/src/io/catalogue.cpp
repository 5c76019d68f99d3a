#include "catalogue.hpp"

#include <fmt/format.h>

#include <fstream>
#include <sstream>

namespace piezo::host {
namespace {

constexpr const char* kHeader =
    "run_dir,utc_start,status,stop_cause,config,t_end_s,axis,angle_end_rad";
/// The header before a run's axes had lines of their own.
constexpr const char* kHeaderBeforeAxes =
    "run_dir,utc_start,status,stop_cause,config,t_end_s,theta_end_rad";

/// Rewrites a catalogue of the earlier shape in this one (written aside and
/// renamed: an interrupted rewrite leaves the old file whole).
void bring_up_to_date(const std::filesystem::path& catalogue) {
  std::ifstream in(catalogue);
  std::string line;
  if (!std::getline(in, line) || line != kHeaderBeforeAxes) return;
  std::ostringstream out;
  out << kHeader << "\n";
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto last = line.rfind(',');  // theta_end_rad: the one axis's angle, unnamed
    out << line.substr(0, last) << "," << line.substr(last) << "\n";
  }
  in.close();
  const std::filesystem::path fresh = catalogue.string() + ".new";
  std::ofstream(fresh) << out.str();
  std::filesystem::rename(fresh, catalogue);
}

}  // namespace

void append_to_catalogue(const std::filesystem::path& run_dir, const CatalogueEntry& e) {
  std::filesystem::path dir = std::filesystem::absolute(run_dir);
  if (dir.filename().empty()) dir = dir.parent_path();  // given as "runs/r1/"
  const std::filesystem::path catalogue = dir.parent_path() / "catalogue.csv";
  const bool fresh = !std::filesystem::exists(catalogue);
  if (!fresh) bring_up_to_date(catalogue);
  std::ofstream out(catalogue, std::ios::app);
  if (fresh) out << kHeader << "\n";
  const std::string run = fmt::format("{},{},{},{},{},{:.6g}", dir.filename().string(), e.utc_start,
                                      e.status, e.stop_cause, e.config, e.t_end_s);
  if (e.axes.empty()) out << run << ",,\n";  // a run that got no axis going: still listed
  for (const CatalogueEntry::Axis& a : e.axes) {
    out << fmt::format("{},{},{:.9g}\n", run, a.name, a.angle_end_rad);
  }
}

}  // namespace piezo::host
