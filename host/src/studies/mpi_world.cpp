// The module libpiezo_mpi.so: MpiWorld over Open MPI's C API.
#include "mpi_world.hpp"

// The C API only: Open MPI's deprecated C++ bindings are not linked.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>

namespace piezo::host {
namespace {

void init(int& rank, int& size) {
  int provided = 0;
  // Only the calling thread talks MPI; the worker threads simulate.
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
}

void finalize() {
  MPI_Finalize();
}

void sum_to_root(const double* values, double* sum, int n) {
  MPI_Reduce(values, sum, n, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
}

constexpr MpiWorld kWorld{init, finalize, sum_to_root};

}  // namespace
}  // namespace piezo::host

extern "C" const piezo::host::MpiWorld* piezo_mpi_world() {
  return &piezo::host::kWorld;
}
