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
#include <bit>

#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model::hybrid {

/// Order of the series: orders 12-13 missed near-grazing reversals at 5 Hz
/// in the prototype issue 23 measured.
inline constexpr int kOrder = 14;
using Coefficients = std::array<double, kOrder + 1>;

/// Powers t, t^2, t^4 and t^8 of a point: what Estrin's scheme multiplies by.
struct Powers {
  explicit Powers(double t) : p{t, t * t, 0.0, 0.0} {
    p[2] = p[1] * p[1];
    p[3] = p[2] * p[2];
  }
  std::array<double, 4> p;
};

/// sum_k c[k] t^k over N coefficients by Estrin's scheme: the lower half
/// plus t^m times the upper (m the largest power of two below N), each
/// half the same way, unrolled at compile time. Its chain of dependent
/// operations is log2(N) multiply-adds long (four for the series),
/// against N - 1 for Horner's: the evaluations sit on each step's critical
/// path (the probes, the root's iterations, the state at the step's end).
template <std::size_t N>
[[nodiscard]] inline double estrin(const double* c, const Powers& t) {
  static_assert(N >= 1 && N <= 16, "t^8 is the highest power kept");
  if constexpr (N == 1) {
    return c[0];
  } else {
    constexpr std::size_t m = std::bit_floor(N - 1);
    return estrin<m>(c, t) + t.p[std::countr_zero(m)] * estrin<N - m>(c + m, t);
  }
}

/// The series at tau.
[[nodiscard]] inline double at(const Coefficients& c, double tau) {
  return estrin<kOrder + 1>(c.data(), Powers(tau));
}

/// Its derivative at tau: the derivative's coefficient k is (k + 1) c[k + 1].
[[nodiscard]] inline double slope_at(const Coefficients& c, double tau) {
  std::array<double, kOrder> d;
  for (std::size_t k = 0; k < kOrder; ++k) d[k] = static_cast<double>(k + 1) * c[k + 1];
  return estrin<kOrder>(d.data(), Powers(tau));
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
