#include "piezo/model/hybrid/stick_rosenbrock.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::model::hybrid {
namespace {

// RODAS4 (E. Hairer, G. Wanner, Solving Ordinary Differential Equations II,
// section IV.7), in the form (I/(gamma h) - J) k_i = f(t + c_i h, y0 +
// sum a_ij k_j) + sum c_ij k_j / h + h d_i f_t; the solution is y0 + sum of
// a_5j k_j + k5 + k6, and k6 is the error estimate.
constexpr double gamma = 0.25;
constexpr double c2 = 0.386, c3 = 0.21, c4 = 0.63;
constexpr double d1 = 0.25, d2 = -0.1043, d3 = 0.1035, d4 = -0.3620000000000023e-01;
constexpr double a21 = 0.1544e1;
constexpr double a31 = 0.9466785280815826, a32 = 0.2557011698983284;
constexpr double a41 = 0.3314825187068521e1, a42 = 0.2896124015972201e1, a43 = 0.9986419139977817;
constexpr double a51 = 0.1221224509226641e1, a52 = 0.6019134481288629e1, a53 = 0.1253708332932087e2,
                 a54 = -0.6878860361058950;
constexpr double c21 = -0.56688e1;
constexpr double c31 = -0.2430093356833875e1, c32 = -0.2063599157091915;
constexpr double c41 = -0.1073529058151375, c42 = -0.9594562251023355e1,
                 c43 = -0.2047028614809616e2;
constexpr double c51 = 0.7496443313967647e1, c52 = -0.1024680431464352e2,
                 c53 = -0.3399990352819905e2, c54 = 0.1170890893206160e2;
constexpr double c61 = 0.8083246795921522e1, c62 = -0.7981132988064893e1,
                 c63 = -0.3152159432874371e2, c64 = 0.1631930543123136e2,
                 c65 = -0.6058818238834054e1;

/// (g I - J) k = r for the motor's Jacobian, g = 1 / (gamma h). The rows of
/// x and theta say only g k_x - k_x' = r_x and g k_theta - k_theta' =
/// r_theta, and no other row takes x or theta but x'' (the spring): they are
/// eliminated, leaving three unknowns (x', theta', z): a 3 x 3 inverse
/// instead of a 5 x 5 LU and its triangular solves.
class ReducedSystem {
 public:
  using Vector = Eigen::Matrix<double, 5, 1>;
  using Matrix = Eigen::Matrix<double, 5, 5>;

  ReducedSystem(const Matrix& J, double g)
      : g_(g), spring_(J(kXDot, kX)), inverse_(reduced(J, g).inverse()) {}

  [[nodiscard]] Vector solve(const Vector& r) const {
    const Eigen::Vector3d k =
        inverse_ * Eigen::Vector3d(r(kXDot) + spring_ * r(kX) / g_, r(kThetaDot), r(kZ));
    Vector out;
    out(kX) = (r(kX) + k(0)) / g_;
    out(kXDot) = k(0);
    out(kTheta) = (r(kTheta) + k(1)) / g_;
    out(kThetaDot) = k(1);
    out(kZ) = k(2);
    return out;
  }

 private:
  static Eigen::Matrix3d reduced(const Matrix& J, double g) {
    Eigen::Matrix3d A;
    A << g - J(kXDot, kXDot) - J(kXDot, kX) / g, -J(kXDot, kThetaDot), -J(kXDot, kZ),
        -J(kThetaDot, kXDot), g - J(kThetaDot, kThetaDot), -J(kThetaDot, kZ),  //
        -J(kZ, kXDot), -J(kZ, kThetaDot), g - J(kZ, kZ);
    return A;
  }

  double g_, spring_;
  Eigen::Matrix3d inverse_;  ///< by cofactors: six solves a step cost six products
};

}  // namespace

StickRosenbrock::StickRosenbrock(const MotorParameters& p, const LuGreState& atol, double rtol)
    : p_(p), kappa_(p.sigma0 / p.F_c()), rtol_(rtol) {
  for (int i = 0; i < 5; ++i) atol_(i) = atol[static_cast<std::size_t>(i)];
}

StickRosenbrock::Vector StickRosenbrock::f(const Vector& y, double V, double s) const {
  const double v = y(kXDot) - p_.r * y(kThetaDot);
  const double z_rate = v * (1.0 - s * kappa_ * y(kZ));
  const double F = p_.sigma0 * y(kZ) + p_.sigma1 * z_rate + p_.sigma2 * v;
  Vector d;
  d << y(kXDot), (p_.K * p_.d_e * V - p_.C * y(kXDot) - p_.K * y(kX) - F) / p_.M, y(kThetaDot),
      p_.r * F / p_.J, z_rate;
  return d;
}

StickRosenbrock::Matrix StickRosenbrock::jacobian(const Vector& y, double s) const {
  const double v = y(kXDot) - p_.r * y(kThetaDot);
  const double g = 1.0 - s * kappa_ * y(kZ);
  // Partial derivatives of F_f and z' by x', theta' and z.
  const double F_X = p_.sigma1 * g + p_.sigma2;
  const double F_z = p_.sigma0 - p_.sigma1 * s * kappa_ * v;
  Matrix J = Matrix::Zero();
  J(kX, kXDot) = 1.0;
  J(kXDot, kX) = -p_.K / p_.M;
  J(kXDot, kXDot) = (-p_.C - F_X) / p_.M;
  J(kXDot, kThetaDot) = p_.r * F_X / p_.M;
  J(kXDot, kZ) = -F_z / p_.M;
  J(kTheta, kThetaDot) = 1.0;
  J(kThetaDot, kXDot) = p_.r * F_X / p_.J;
  J(kThetaDot, kThetaDot) = -p_.r * p_.r * F_X / p_.J;
  J(kThetaDot, kZ) = p_.r * F_z / p_.J;
  J(kZ, kXDot) = g;
  J(kZ, kThetaDot) = -p_.r * g;
  J(kZ, kZ) = -s * kappa_ * v;
  return J;
}

void StickRosenbrock::derivative(const LuGreState& y, double V, double s, LuGreState& dydt) const {
  const Vector d = f(Vector(y.data()), V, s);
  for (int i = 0; i < 5; ++i) dydt[static_cast<std::size_t>(i)] = d(i);
}

double StickRosenbrock::step(const LuGreState& y, double V, double slope, double s, double h,
                             LuGreState& out) const {
  const Vector y0(y.data());
  Vector f_t = Vector::Zero();
  f_t(kXDot) = p_.K * p_.d_e * slope / p_.M;
  const ReducedSystem lu(jacobian(y0, s), 1.0 / (gamma * h));
  const double inv_h = 1.0 / h;
  const Vector k1 = lu.solve(f(y0, V, s) + h * d1 * f_t);
  const Vector k2 =
      lu.solve(f(y0 + a21 * k1, V + c2 * h * slope, s) + h * d2 * f_t + c21 * inv_h * k1);
  const Vector k3 = lu.solve(f(y0 + a31 * k1 + a32 * k2, V + c3 * h * slope, s) + h * d3 * f_t +
                             inv_h * (c31 * k1 + c32 * k2));
  const Vector k4 = lu.solve(f(y0 + a41 * k1 + a42 * k2 + a43 * k3, V + c4 * h * slope, s) +
                             h * d4 * f_t + inv_h * (c41 * k1 + c42 * k2 + c43 * k3));
  const double V1 = V + h * slope;
  const Vector y5 = y0 + a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4;
  const Vector k5 = lu.solve(f(y5, V1, s) + inv_h * (c51 * k1 + c52 * k2 + c53 * k3 + c54 * k4));
  const Vector y6 = y5 + k5;
  const Vector k6 =
      lu.solve(f(y6, V1, s) + inv_h * (c61 * k1 + c62 * k2 + c63 * k3 + c64 * k4 + c65 * k5));
  const Vector y1 = y6 + k6;
  for (int i = 0; i < 5; ++i) out[static_cast<std::size_t>(i)] = y1(i);
  const Vector scale = atol_.array() + rtol_ * y0.cwiseAbs().cwiseMax(y1.cwiseAbs()).array();
  return std::sqrt((k6.array() / scale.array()).square().mean());
}

}  // namespace piezo::model::hybrid
