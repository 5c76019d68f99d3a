#pragma once
// The ranks of an MPI launch (mpirun -n N, or srun on a SLURM cluster): a
// study's runs are split among them, each rank using all its cores, and
// rank 0 gathers the outputs, computes and writes the results. Without an
// MPI launcher in the environment (or in a build without MPI) there is one
// rank and MPI is never loaded (mpi_world.hpp).

#include <vector>

namespace piezo::host {

struct MpiWorld;

class MpiRanks {
 public:
  /// Initialises MPI on first use when started by an MPI launcher.
  static MpiRanks& get();

  [[nodiscard]] int rank() const { return rank_; }
  [[nodiscard]] int size() const { return size_; }
  [[nodiscard]] bool root() const { return rank_ == 0; }
  /// Sums every rank's `values` into rank 0's (each entry computed by one
  /// rank, zero on the others: the sum is exact).
  void gather_to_root(std::vector<double>& values) const;

  MpiRanks(const MpiRanks&) = delete;
  MpiRanks& operator=(const MpiRanks&) = delete;
  ~MpiRanks();

 private:
  MpiRanks();
  int rank_ = 0;
  int size_ = 1;
  const MpiWorld* world_ = nullptr;  ///< loaded only under an MPI launcher
};

}  // namespace piezo::host
