#include "mpi_ranks.hpp"

#include <cstdlib>

#include "io/module_loader.hpp"
#include "mpi_world.hpp"

namespace piezo::host {
namespace {

// Set by mpirun (Open MPI) and by srun with PMI or PMIx.
bool launched_by_mpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

}  // namespace

MpiRanks& MpiRanks::get() {
  static MpiRanks ranks;
  return ranks;
}

MpiRanks::MpiRanks() {
#ifdef PIEZO_HAVE_MPI
  if (!launched_by_mpi()) return;
  using Entry = const MpiWorld* (*)();
  world_ = reinterpret_cast<Entry>(
      module_entry("libpiezo_mpi.so", "piezo_mpi_world", ModuleScope::global))();
  world_->init(rank_, size_);
#else
  (void)launched_by_mpi;
#endif
}

MpiRanks::~MpiRanks() {
  if (world_ != nullptr) world_->finalize();
}

void MpiRanks::gather_to_root(std::vector<double>& values) const {
  if (size_ == 1 || world_ == nullptr) return;
  std::vector<double> sum(values.size(), 0.0);
  world_->sum_to_root(values.data(), sum.data(), static_cast<int>(values.size()));
  if (root()) values = std::move(sum);
}

}  // namespace piezo::host
