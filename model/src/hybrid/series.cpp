#include "piezo/model/hybrid/series.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "piezo/model/hybrid/nth_root.hpp"

namespace piezo::model::hybrid {

LuGreState Expansion::state(double tau) const {
  const Powers t(tau);
  LuGreState out{};
  for (std::size_t i = 0; i < 5; ++i) out[i] = estrin<kOrder + 1>(y[i].data(), t);
  return out;
}

namespace {

/// The middle of order K's Cauchy product, sum_j v[j] z[K-j] for 0 < j < K
/// (its ends, v[K] z[0] and v[0] z[K], are folded into the recurrence's
/// coefficients). Summed oldest coefficients first, in two chains, so that
/// it waits least on the order just computed. Unrolled at compile time:
/// every index a constant.
template <std::size_t K, std::size_t... J>
double cauchy_middle(const Coefficients& v, const Coefficients& z, std::index_sequence<J...>) {
  double lo = K % 2 == 0 && K > 0 ? v[K / 2] * z[K / 2] : 0.0, hi = 0.0;
  // J = 0, 1, ... walks j = (K - 1)/2 down to 1: the pairs (j, K - j).
  ((lo += v[(K - 1) / 2 - J] * z[K - (K - 1) / 2 + J],
    hi += v[K - (K - 1) / 2 + J] * z[(K - 1) / 2 - J]),
   ...);
  return lo + hi;
}

template <std::size_t K>
double cauchy_middle(const Coefficients& v, const Coefficients& z) {
  return cauchy_middle<K>(v, z, std::make_index_sequence < K <= 1 ? 0 : (K - 1) / 2 > {});
}

}  // namespace

SeriesMotor::SeriesMotor(const MotorParameters& p)
    : p_(p), kappa_(p.sigma0 / p.F_c()), K_d_e_(p.K * p.d_e) {
  const double r_over_J = p.r / p.J;
  for (std::size_t k = 0; k <= kOrder; ++k) {
    const double inv = 1.0 / static_cast<double>(k + 1);
    per_order_[k] = {inv, inv / p.M, r_over_J * inv, inv * (1.0 / p.M + p.r * r_over_J)};
  }
}

void SeriesMotor::expand(const LuGreState& y0, double V0, double slope, double s, bool saturated,
                         Expansion& e) const {
  if (saturated) {
    expand<true>(y0, V0, slope, s, e);
  } else {
    expand<false>(y0, V0, slope, s, e);
  }
}

template <bool Saturated>
void SeriesMotor::expand(const LuGreState& y0, double V0, double slope, double s,
                         Expansion& e) const {
  // Plain references, not a structured binding: the lambda below captures
  // them (clang before 16 refuses to capture a binding).
  Coefficients &x = e.y[kX], &X = e.y[kXDot], &th = e.y[kTheta], &W = e.y[kThetaDot];
  Coefficients &z = e.y[kZ], &v = e.v;
  x[0] = y0[kX];
  X[0] = y0[kXDot];
  th[0] = y0[kTheta];
  W[0] = y0[kThetaDot];
  z[0] = y0[kZ];
  v[0] = X[0] - p_.r * W[0];
  // z' = v - sk (v z); a saturated bristle is held (z' = 0), which leaves
  // the recurrence linear: no Cauchy term. F_f = sigma0 z + sigma1 z' +
  // sigma2 v = P - q (v z), with P = sigma0 z + a v.
  const double sk = s * kappa_;
  const double a = Saturated ? p_.sigma2 : p_.sigma1 + p_.sigma2;
  const double q = p_.sigma1 * sk;
  // Order k's Cauchy term (v z)[k] is v[k] z0 + v0 z[k] + its middle, which
  // waits only on older orders. Folding its ends into the coefficients of
  // v[k] and z[k] leaves -F_f[k] = cv v[k] + cz z[k] + q middle: two
  // multiply-adds from the order before, and one more to each new
  // coefficient. That chain sets the recurrence's cost; the rest is
  // computed beside it. Every order is its own instance, unrolled: no loop,
  // no branch.
  // The constants in registers: a store into e might, for all the compiler
  // knows, change the motor's, which it would then load after every one.
  const double sigma0 = p_.sigma0, C = p_.C, K_spring = p_.K, K_d_e = K_d_e_;
  const double z0 = z[0], v0 = v[0];
  const double cv = q * z0 - a, cz = q * v0 - sigma0;
  const double zv = 1.0 - sk * z0, zz = -sk * v0;  // z' = zv v + zz z - sk middle
  auto order = [&]<std::size_t K>() __attribute__((always_inline)) {
    const PerOrder& o = per_order_[K];
    const double Vk = K == 0 ? V0 : (K == 1 ? slope : 0.0);
    // M x'' + F_f, with x'[k] (the order before's) last.
    const double A = (K_d_e * Vk - K_spring * x[K]) - C * X[K];
    x[K + 1] = X[K] * o.inv;
    th[K + 1] = W[K] * o.inv;
    if constexpr (Saturated) {
      const double P = sigma0 * z[K] + a * v[K];
      X[K + 1] = (A - P) * o.inv_M;
      W[K + 1] = P * o.r_over_J;
      z[K + 1] = 0.0;
      v[K + 1] = A * o.inv_M - P * o.to_v;
    } else if constexpr (K == 0) {
      const double G = q * v0 * z0 - sigma0 * z0 - a * v0;  // -F_f
      X[1] = (A + G) * o.inv_M;
      W[1] = -G * o.r_over_J;
      z[1] = v0 - sk * v0 * z0;
      v[1] = A * o.inv_M + G * o.to_v;
    } else {
      const double middle = cauchy_middle<K>(v, z);
      const double G = cv * v[K] + (cz * z[K] + q * middle);  // -F_f
      const double A_M = A * o.inv_M;
      X[K + 1] = G * o.inv_M + A_M;
      W[K + 1] = -G * o.r_over_J;
      z[K + 1] = (zv * v[K] + (zz * z[K] - sk * middle)) * o.inv;
      // x'[k+1] - r theta'[k+1] = (A + G) inv_M + r G r_over_J.
      v[K + 1] = G * o.to_v + A_M;
    }
  };
  [&]<std::size_t... K>(std::index_sequence<K...>) {
    (order.template operator()<K>(), ...);
  }
  (std::make_index_sequence<kOrder>{});
}

namespace {

const NthRoot<kOrder - 1> kRootBefore;
const NthRoot<kOrder> kRootLast;

/// x^n by squaring: a short chain of multiplications.
double power(double x, int n) {
  double out = 1.0;
  for (; n > 0; n >>= 1, x *= x)
    if (n & 1) out *= x;
  return out;
}

}  // namespace

LuGreState inverse(const LuGreState& scale) {
  LuGreState out{};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = 1.0 / scale[i];
  return out;
}

double allowed_step(const Expansion& e, const LuGreState& inverse_scale, double tolerance,
                    double h_max) {
  double h = h_max;
  double last = 0.0, before = 0.0;  // the largest scaled coefficient of each order
  for (std::size_t i = 0; i < 5; ++i) {
    last = std::max(last, std::abs(e.y[i][kOrder]) * inverse_scale[i]);
    before = std::max(before, std::abs(e.y[i][kOrder - 1]) * inverse_scale[i]);
  }
  // A bound is below the step so far only if its coefficient times that
  // step's power exceeds the tolerance: the roots only then. The order before the last binds first
  // as a rule (a coefficient falls by about omega h / k an order), so it is tried first and the
  // last order's root is rarely needed.
  if (before * power(h, kOrder - 1) > tolerance) {
    h = kRootBefore(tolerance / before);
  }
  if (last * power(h, kOrder) > tolerance) {
    h = kRootLast(tolerance / last);
  }
  return h;
}

namespace {

/// The series' second derivative at tau, by Estrin's scheme as at().
double curvature_at(const Coefficients& c, double tau) {
  std::array<double, kOrder - 1> d;
  for (std::size_t k = 0; k + 1 < kOrder; ++k) {
    d[k] = static_cast<double>((k + 2) * (k + 1)) * c[k + 2];
  }
  return estrin<kOrder - 1>(d.data(), Powers(tau));
}

/// s*v and its slope at one end of a bracket: each evaluated once.
struct End {
  double value, slope;
};

End end_at(const Coefficients& v, double s, double tau) {
  return {s * at(v, tau), s * slope_at(v, tau)};
}

/// Where the cubic through both ends' values and slopes first crosses zero
/// in (a, b): two Newton steps on the cubic from the chord, which cost no
/// evaluation of the series. The chord if they leave the bracket; the
/// midpoint when s*v(a) = 0 (a reversal just passed: the cubic's root at a
/// is not the one sought).
double cubic_start(double a, double b, const End& start, const End& end) {
  if (start.value <= 0.0) return 0.5 * (a + b);
  const double chord = start.value / (start.value - end.value);
  const double w = b - a, m0 = w * start.slope, m1 = w * end.slope;
  const double c2 = 3.0 * (end.value - start.value) - 2.0 * m0 - m1;
  const double c3 = 2.0 * (start.value - end.value) + m0 + m1;
  double u = chord;
  for (int i = 0; i < 2; ++i) {
    const double p = start.value + u * (m0 + u * (c2 + u * c3));
    const double d = m0 + u * (2.0 * c2 + u * 3.0 * c3);
    u = d != 0.0 ? u - p / d : chord;
    if (!(u > 0.0 && u < 1.0)) u = chord;
  }
  return a + w * u;
}

/// The first root of s*v in (a, b], given its value and slope at each end
/// (s*v(a) >= 0 > s*v(b)): Halley's method (the series' value, slope and
/// curvature evaluated side by side; cubic convergence) from the cubic's
/// root, kept inside the bracket by bisection. Returns a point where
/// s*v < 0, past the root by at most 1e-12 of the step, so that the step
/// ends with the contact's new sign.
double first_root(const Coefficients& v, double s, double a, double b, const End& start,
                  const End& end) {
  const double resolution = 1e-12 * b;
  // A Halley step this short leaves the next iterate within about its cube
  // of the root: close enough to try the points just either side of it.
  // Near a double root, where it is slow, the try fails and the bracket
  // moves on.
  const double near = 1e-4 * b;
  double lo = a, hi = b;
  double tau = cubic_start(a, b, start, end);
  for (int i = 0; i < 60 && hi - lo > resolution; ++i) {
    const double value = s * at(v, tau);
    const double d = s * slope_at(v, tau);
    const double c = s * curvature_at(v, tau);
    (value >= 0.0 ? lo : hi) = tau;
    const double denominator = 2.0 * d * d - value * c;
    const double next = denominator != 0.0 ? tau - 2.0 * value * d / denominator : 0.5 * (lo + hi);
    if (std::abs(next - tau) <= near) {
      // The root within the resolution around next if s*v changes sign
      // across it: both sides evaluated side by side. (The try alone would
      // let a root near a double one, where Halley's error constant is
      // large, be missed by far more than the resolution.)
      const double before = next - 0.5 * resolution, past = next + 0.5 * resolution;
      if (before > lo && past < hi) {
        const double value_before = s * at(v, before), value_past = s * at(v, past);
        if (value_before < 0.0) {
          hi = before;
        } else if (value_past < 0.0) {
          return past;
        } else {
          lo = past;
        }
      }
    }
    tau = next > lo && next < hi ? next : 0.5 * (lo + hi);
  }
  return hi;
}

/// Where the cubic through both ends' values and slopes has its minimum in
/// (a, b), given s*v' < 0 at a and > 0 at b: the slope's linear
/// interpolation, refined by two Newton steps on the cubic's slope.
double cubic_minimum(double a, double b, const End& start, const End& end) {
  const double w = b - a, m0 = w * start.slope, m1 = w * end.slope;
  const double c2 = 3.0 * (end.value - start.value) - 2.0 * m0 - m1;
  const double c3 = 2.0 * (start.value - end.value) + m0 + m1;
  const double linear = m0 / (m0 - m1);
  double u = linear;
  for (int i = 0; i < 2; ++i) {
    const double d = m0 + u * (2.0 * c2 + u * 3.0 * c3);
    const double c = 2.0 * c2 + u * 6.0 * c3;
    u = c > 0.0 ? u - d / c : linear;
    if (!(u > 0.0 && u < 1.0)) u = linear;
  }
  return a + w * u;
}

/// The first root of s*v in (a, b) when s*v >= 0 at both ends, falls at a
/// and rises at b: at most one minimum lies between them (the step cap),
/// and it is sought by Newton on v' from the cubic's minimum only until a
/// point with s*v < 0 brackets the root, or the minimum is plainly above
/// zero, or found to the resolution. Sets `found`.
double root_in_dip(const Coefficients& v, double s, double a, double b, const End& start,
                   const End& end, bool& found) {
  double lo = a, hi = b, tau = cubic_minimum(a, b, start, end);
  const double resolution = 1e-12 * b;
  found = true;
  for (int i = 0; i < 60 && hi - lo > resolution; ++i) {
    const double value = s * at(v, tau);
    const double d = s * slope_at(v, tau);
    if (value < 0.0) return first_root(v, s, a, tau, start, {value, d});
    const double c = s * curvature_at(v, tau);
    (d < 0.0 ? lo : hi) = tau;
    const double next = c > 0.0 ? tau - d / c : 0.5 * (lo + hi);
    // Close to the minimum, s*v there is value - d^2/2c to within a small
    // fraction of that drop: well above zero, there is no root.
    const double drop = c > 0.0 ? 0.5 * d * d / c : value;
    if (d == 0.0 || std::abs(next - tau) <= resolution ||
        (std::abs(next - tau) <= 0.05 * (b - a) && drop <= 0.25 * value)) {
      break;
    }
    tau = next > lo && next < hi ? next : 0.5 * (lo + hi);
  }
  found = false;
  return b;
}

/// The first root of s*v in the half step (a, b], from its ends: a sign
/// change, or a dip below zero (the step cap keeps at most one extremum of
/// v in a half step). Sets `found` to whether there is one.
double root_in(const Coefficients& v, double s, double a, double b, const End& start,
               const End& end, bool& found) {
  found = true;
  if (end.value < 0.0) return first_root(v, s, a, b, start, end);
  if (start.slope < 0.0 && end.slope > 0.0) return root_in_dip(v, s, a, b, start, end, found);
  found = false;
  return b;
}

}  // namespace

double first_zero(const Coefficients& v, double s, double h) {
  // s*v and its slope at both probes, evaluated side by side: the second is
  // wasted when the first half holds the zero, but costs no wait.
  const End start{s * v[0], s * v[1]};
  const End middle = end_at(v, s, 0.5 * h);
  const End end = end_at(v, s, h);

  bool found = false;
  const double tau = root_in(v, s, 0.0, 0.5 * h, start, middle, found);
  return found ? tau : root_in(v, s, 0.5 * h, h, middle, end, found);
}

double sliding_sign(const Coefficients& v) {
  for (const double c : v) {
    if (c != 0.0) return c > 0.0 ? 1.0 : -1.0;
  }
  return 1.0;
}

}  // namespace piezo::model::hybrid
