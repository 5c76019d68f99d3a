#pragma once
// The MPI calls a study makes (mpi_ranks.hpp), from the module
// libpiezo_mpi.so (mpi_world.cpp): Open MPI is loaded only by a process that
// an MPI launcher started, not by every `piezo` command.

namespace piezo::host {

struct MpiWorld {
  /// MPI_Init_thread (funnelled) and this process's rank and the world's size.
  void (*init)(int& rank, int& size);
  void (*finalize)();
  /// Sums `n` values of every rank into `sum` on rank 0.
  void (*sum_to_root)(const double* values, double* sum, int n);
};

}  // namespace piezo::host
