#include "catalogue.hpp"

#include <fmt/format.h>

#include <fstream>

namespace piezo::host {

void append_to_catalogue(const std::filesystem::path& run_dir, const CatalogueEntry& e) {
  std::filesystem::path dir = std::filesystem::absolute(run_dir);
  if (dir.filename().empty()) dir = dir.parent_path();  // given as "runs/r1/"
  const std::filesystem::path catalogue = dir.parent_path() / "catalogue.csv";
  const bool fresh = !std::filesystem::exists(catalogue);
  std::ofstream out(catalogue, std::ios::app);
  if (fresh) out << "run_dir,utc_start,status,stop_cause,config,t_end_s,theta_end_rad\n";
  out << fmt::format("{},{},{},{},{},{:.6g},{:.9g}\n", dir.filename().string(), e.utc_start,
                     e.status, e.stop_cause, e.config, e.t_end_s, e.theta_end_rad);
}

}  // namespace piezo::host
