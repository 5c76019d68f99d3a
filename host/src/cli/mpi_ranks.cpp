#include "mpi_ranks.hpp"

#include <cstdlib>

#ifdef PIEZO_HAVE_MPI
// The C API only: Open MPI's deprecated C++ bindings are not linked.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

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
  int provided = 0;
  // Only the calling thread talks MPI; the worker threads simulate.
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  initialised_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
#else
  (void)launched_by_mpi;
#endif
}

MpiRanks::~MpiRanks() {
#ifdef PIEZO_HAVE_MPI
  if (initialised_) MPI_Finalize();
#endif
}

void MpiRanks::gather_to_root(std::vector<double>& values) const {
#ifdef PIEZO_HAVE_MPI
  if (size_ == 1) return;
  std::vector<double> sum(values.size(), 0.0);
  MPI_Reduce(values.data(), sum.data(), static_cast<int>(values.size()), MPI_DOUBLE, MPI_SUM, 0,
             MPI_COMM_WORLD);
  if (root()) values = std::move(sum);
#else
  (void)values;
#endif
}

}  // namespace piezo::host
