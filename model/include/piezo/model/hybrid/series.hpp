#pragma once
/// @file
/// Series mode of the LuGre hybrid integrator: Taylor series of the motor
/// between two events (a drive corner, a zero of the sliding velocity v).
///
/// With s = sgn(v) fixed the right-hand side is a polynomial whose only
/// nonlinear term is v*z:
///   z' = v - s*kappa*v*z,  F_f = sigma0 z + sigma1 z' + sigma2 v,
///   x'' = (K d_e V(t) - C x' - K x - F_f)/M,  theta'' = r F_f / J,
/// with kappa = sigma0/F_c and V(t) linear on each piece of the drive, so
/// the coefficients follow from the usual recurrence (one Cauchy product of
/// v and z per order). Allocation-free.

#include <array>

#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model::hybrid {

/// Order of the series: orders 12-13 missed near-grazing reversals at 5 Hz
/// in the prototype issue 23 measured.
inline constexpr int kOrder = 14;
using Coefficients = std::array<double, kOrder + 1>;

static_assert(kOrder % 2 == 0, "at() and slope_at() split the coefficients into even and odd");

/// The series at tau: Horner in tau^2 over the even and over the odd
/// coefficients, two chains of half the length that the processor runs side
/// by side (a plain Horner is one chain of kOrder dependent multiply-adds,
/// and the root search evaluates it several times a step).
[[nodiscard]] inline double at(const Coefficients& c, double tau) {
  const double t2 = tau * tau;
  double even = c[kOrder], odd = c[kOrder - 1];
  for (int k = kOrder - 2; k >= 0; k -= 2) {
    even = even * t2 + c[static_cast<std::size_t>(k)];
    if (k >= 1) odd = odd * t2 + c[static_cast<std::size_t>(k - 1)];
  }
  return even + tau * odd;
}

/// Its derivative at tau, the same way: the derivative's coefficient k is
/// (k + 1) c[k + 1].
[[nodiscard]] inline double slope_at(const Coefficients& c, double tau) {
  const double t2 = tau * tau;
  double odd = kOrder * c[kOrder], even = (kOrder - 1) * c[kOrder - 1];
  for (int k = kOrder - 4; k >= 0; k -= 2) {
    even = even * t2 + (k + 1) * c[static_cast<std::size_t>(k + 1)];
    odd = odd * t2 + (k + 2) * c[static_cast<std::size_t>(k + 2)];
  }
  return even + tau * odd;
}

/// The series of the five states and of v about one point.
struct Expansion {
  std::array<Coefficients, 5> y;  ///< x, x', theta, theta', z
  Coefficients v;                 ///< x' - r theta'

  [[nodiscard]] LuGreState state(double tau) const;
};

/// The motor's recurrence with its constant ratios worked out once.
class SeriesMotor {
 public:
  explicit SeriesMotor(const MotorParameters& p);

  /// The series about y0, with V = V0 + slope*tau and the sliding sign s.
  /// A saturated bristle (z = s/kappa, finished in closed form) is held
  /// there: z' = 0, F_f = s F_c + sigma2 v, as in the linear mode (left to
  /// the recurrence, its decay rate kappa |v| would bound the step).
  void expand(const LuGreState& y0, double V0, double slope, double s, bool saturated,
              Expansion& e) const;

 private:
  /// What order k multiplies by: 1/(k+1), and that over M, times r/J, and
  /// times (1/M + r^2/J) (from F_f to v's coefficient).
  struct PerOrder {
    double inv, inv_M, r_over_J, to_v;
  };
  template <bool Saturated>
  void expand(const LuGreState& y0, double V0, double slope, double s, Expansion& e) const;
  MotorParameters p_;
  double kappa_, K_d_e_;
  std::array<PerOrder, kOrder + 1> per_order_{};
};

/// Each state's 1 / scale: what the step bound multiplies by (a division
/// per state and step otherwise).
[[nodiscard]] LuGreState inverse(const LuGreState& scale);

/// The step the series allows: the last two orders' coefficients, against
/// each state's scale (given as its inverse), held to `tolerance`, and at
/// most h_max.
[[nodiscard]] double allowed_step(const Expansion& e, const LuGreState& inverse_scale,
                                  double tolerance, double h_max);

/// Where s*v first turns negative in (0, h] (h when it does not): a sign
/// change at h/2 or h, or a dip of s*v below zero inside a half step (the
/// step cap keeps at most one extremum of v in a half step). Refined by
/// Newton on the polynomial.
[[nodiscard]] double first_zero(const Coefficients& v, double s, double h);

/// The sign the contact slides with from a point where v may be zero: that
/// of v, else of its first nonzero derivative there.
[[nodiscard]] double sliding_sign(const Coefficients& v);

}  // namespace piezo::model::hybrid
