#pragma once
/// @file
/// Global sensitivity over many parameters at once (the paper's future
/// work: "the sensitivity of additional parameters"). Designs and
/// estimators only; the caller evaluates the model on the design's rows.
///  - Sobol' indices: first order (Saltelli 2010) and total (Jansen 1999)
///    on a Saltelli design drawn from a Sobol' low-discrepancy sequence
///    (Boost.Random), with bootstrap intervals.
///  - Morris elementary effects: mu, mu* and sigma over r trajectories.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace piezo::model {

/// One uncertain input, uniform on [low, high].
struct Factor {
  std::string name;
  double low;
  double high;
};

using DesignRows = std::vector<std::vector<double>>;

/// The Saltelli design, in OpenTURNS's order: A (n rows), B (n rows), then
/// for each factor i the rows of A with column i taken from B. A and B are
/// the two halves of each point of a 2k-dimensional Sobol' sequence; `skip`
/// points are discarded first (a different skip, another design).
[[nodiscard]] DesignRows saltelli_design(const std::vector<Factor>& factors, std::size_t n,
                                         std::uint64_t skip = 0);

struct SobolIndices {
  std::vector<double> first, total;           ///< S_i, ST_i
  std::vector<double> first_low, first_high;  ///< bootstrap 95 % intervals
  std::vector<double> total_low, total_high;
  double variance = 0.0;  ///< of the output over A and B
};

/// Indices from the outputs y of saltelli_design's rows (n (k + 2) values);
/// `use_n` <= n takes the first use_n points of each block (convergence).
[[nodiscard]] SobolIndices sobol_indices(std::span<const double> y, std::size_t n, std::size_t k,
                                         std::size_t use_n, int bootstrap, std::uint64_t seed);

/// Morris trajectories on a p-level grid (p = 4, step p / (2 (p - 1))):
/// r trajectories of k + 1 rows, each moving one factor at a time.
struct MorrisDesign {
  DesignRows rows;
  std::vector<std::size_t> moved;  ///< per step (row j+1 of a trajectory): the factor moved
  std::vector<double> delta;       ///< the signed step in [0, 1] units
  std::size_t trajectories = 0;
};
[[nodiscard]] MorrisDesign morris_design(const std::vector<Factor>& factors, std::size_t r,
                                         std::uint64_t seed);

struct MorrisIndices {
  std::vector<double> mu, mu_star, sigma;
};
[[nodiscard]] MorrisIndices morris_indices(const MorrisDesign& design, std::size_t k,
                                           std::span<const double> y);

}  // namespace piezo::model
