#include "piezo/model/hybrid/linear_slide.hpp"

#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>

namespace piezo::model::hybrid {

LinearSlide::LinearSlide(const MotorParameters& p, double step)
    : p_(p), h_(step), kappa_(p.sigma0 / p.F_c()) {}

void LinearSlide::saturate(LuGreState& y, double s) const {
  const double v = y[kXDot] - p_.r * y[kThetaDot];
  const double rest = 1.0 - s * kappa_ * y[kZ];
  const double delay = 1.0 / (kappa_ * std::abs(v));
  const double impulse = (p_.sigma1 * v - s * p_.F_c()) * rest * delay;
  const double dX = -impulse / p_.M;
  const double dW = p_.r * impulse / p_.J;
  // Applied `delay` later: the same as the velocity change now and the
  // positions held back by it over the delay.
  y[kXDot] += dX;
  y[kX] -= dX * delay;
  y[kThetaDot] += dW;
  y[kTheta] -= dW * delay;
  y[kZ] = s / kappa_;
}

const LinearSlide::Matrix& LinearSlide::propagator(double s, double slope) {
  for (const Cached& c : cache_) {
    if (c.s == s && c.slope == slope) return c.phi;
  }
  // x' = X; X' = (K d_e V - C X - K x - s F_c - sigma2 v)/M; theta' = W;
  // W' = r (s F_c + sigma2 v)/J; V' = slope; with v = X - r W.
  const MotorParameters& p = p_;
  Matrix A = Matrix::Zero();
  A(0, 1) = 1.0;
  A(1, 0) = -p.K / p.M;
  A(1, 1) = -(p.C + p.sigma2) / p.M;
  A(1, 3) = p.sigma2 * p.r / p.M;
  A(1, 4) = p.K * p.d_e / p.M;
  A(1, 5) = -s * p.F_c() / p.M;
  A(2, 3) = 1.0;
  A(3, 1) = p.r * p.sigma2 / p.J;
  A(3, 3) = -p.r * p.r * p.sigma2 / p.J;
  A(3, 5) = p.r * s * p.F_c() / p.J;
  A(4, 5) = slope;
  Cached& slot = cache_[oldest_];
  oldest_ = (oldest_ + 1) % cache_.size();
  slot.s = s;
  slot.slope = slope;
  slot.phi = (A * h_).exp();
  return slot.phi;
}

void LinearSlide::advance(LuGreState& y, double V, double slope, double s) {
  const Matrix& phi = propagator(s, slope);
  Eigen::Matrix<double, 6, 1> w;
  w << y[kX], y[kXDot], y[kTheta], y[kThetaDot], V, 1.0;
  const Eigen::Matrix<double, 6, 1> next = phi * w;
  y[kX] = next(0);
  y[kXDot] = next(1);
  y[kTheta] = next(2);
  y[kThetaDot] = next(3);
}

}  // namespace piezo::model::hybrid
