#pragma once
/// @file
/// Linear mode of the LuGre hybrid integrator: a contact sliding with a
/// saturated bristle (z = s F_c/sigma0) is a linear system, F_f = s F_c +
/// sigma2 v, propagated exactly by a cached matrix exponential of the
/// augmented system (x, x', theta, theta', V, 1) in fixed steps.

#include <Eigen/Dense>
#include <array>

#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model::hybrid {

class LinearSlide {
 public:
  /// @param step the fixed step [s]
  LinearSlide(const MotorParameters& p, double step);

  [[nodiscard]] double step() const { return h_; }

  /// Finishes a bristle close to saturation (1 - s kappa z small) in closed
  /// form: with v about constant, 1 - s kappa z decays as exp(-kappa |v| t),
  /// and the rest of the flip hands the contact the impulse of
  /// (sigma1 v - s F_c)(1 - s kappa z) over that decay, applied at its
  /// centroid 1/(kappa |v|) later. Leaves z = s/kappa.
  void saturate(LuGreState& y, double s) const;

  /// Advances a saturated state by one step with the drive V(t) = V + slope t.
  void advance(LuGreState& y, double V, double slope, double s);

 private:
  using Matrix = Eigen::Matrix<double, 6, 6>;
  struct Cached {
    double s = 0.0, slope = 0.0;
    Matrix phi;
  };
  const Matrix& propagator(double s, double slope);

  MotorParameters p_;
  double h_, kappa_;
  std::array<Cached, 4> cache_{};  ///< a sawtooth has two slopes and two directions
  std::size_t oldest_ = 0;
};

}  // namespace piezo::model::hybrid
