#include "piezo/model/hybrid/series.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::model::hybrid {

LuGreState Expansion::state(double tau) const {
  LuGreState out{};
  for (std::size_t i = 0; i < 5; ++i) out[i] = at(y[i], tau);
  return out;
}

namespace {

/// The terms of order k's Cauchy product sum_j v[j] z[k-j] but its two
/// ends (the coefficients just computed): summed from the middle out, the
/// oldest coefficients first, so that the newest (v[k-1], z[k-1]) come last
/// and the sum is ready soon after them.
double cauchy_middle(const Coefficients& v, const Coefficients& z, std::size_t k) {
  if (k < 2) return 0.0;
  double lo = 0.0, hi = 0.0;
  std::size_t j = k / 2, l = k - j;  // j + l = k
  if (j == l) {
    lo = v[j] * z[j];  // k even: the centre term, once
    --j;
    ++l;
  }
  for (; j >= 1; --j, ++l) {
    lo += v[j] * z[l];
    hi += v[l] * z[j];
  }
  return lo + hi;
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
  auto& [x, X, th, W, z] = e.y;
  auto& v = e.v;
  x[0] = y0[kX];
  X[0] = y0[kXDot];
  th[0] = y0[kTheta];
  W[0] = y0[kThetaDot];
  z[0] = y0[kZ];
  v[0] = X[0] - p_.r * W[0];
  // z' = zv v - sk (v z): a saturated bristle is held (z' = 0).
  const double zv = saturated ? 0.0 : 1.0;
  const double sk = saturated ? 0.0 : s * kappa_;
  // F_f = sigma0 z + sigma1 z' + sigma2 v = P - q (v z), with P the part
  // known before the order's Cauchy term.
  const double a = p_.sigma1 * zv + p_.sigma2;
  const double q = p_.sigma1 * sk;
  // Each order's new coefficients hang on the Cauchy term of the one before
  // by one multiply-add each (v and z directly, not v through x' and
  // theta'): the recurrence's chain of dependent operations, which sets
  // its cost, is three per order. The rest is computed beside it.
  for (std::size_t k = 0; k < kOrder; ++k) {
    const double vz = k == 0 ? v[0] * z[0] : v[k] * z[0] + (v[0] * z[k] + cauchy_middle(v, z, k));
    const PerOrder& o = per_order_[k];
    const double Vk = k == 0 ? V0 : (k == 1 ? slope : 0.0);
    const double A = K_d_e_ * Vk - p_.C * X[k] - p_.K * x[k];  // M x'' + F_f
    const double P = p_.sigma0 * z[k] + a * v[k];
    const double F = P - q * vz;
    x[k + 1] = X[k] * o.inv;
    X[k + 1] = (A - F) * o.inv_M;
    th[k + 1] = W[k] * o.inv;
    W[k + 1] = F * o.r_over_J;
    z[k + 1] = zv * o.inv * v[k] - sk * o.inv * vz;
    // x'[k+1] - r theta'[k+1] = (A - F) inv_M - r F r_over_J.
    v[k + 1] = (A * o.inv_M - P * o.to_v) + q * o.to_v * vz;
  }
}

namespace {

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
  // step's power exceeds the tolerance: the roots (a costly pow each) only then.
  if (last * power(h, kOrder) > tolerance) {
    h = std::min(h, std::pow(tolerance / last, 1.0 / kOrder));
  }
  if (before * power(h, kOrder - 1) > tolerance) {
    h = std::min(h, std::pow(tolerance / before, 1.0 / (kOrder - 1)));
  }
  return h;
}

namespace {

/// s*v and its slope at one end of a bracket: each evaluated once.
struct End {
  double value, slope;
};

/// The first root of s*v in (a, b], given its value at each end (s*v(a) >=
/// 0 > s*v(b)): Newton from the chord (the midpoint when v(a) = 0, a
/// reversal just passed), kept inside the bracket by bisection. (A start
/// from the cubic through both ends' slopes too saved an iteration a root
/// but cost more than it saved.) Returns a point where s*v < 0,
/// past the root by at most 1e-12 of the step, so that the step ends with
/// the contact's new sign.
double first_root(const Coefficients& v, double s, double a, double b, const End& start,
                  const End& end) {
  const double resolution = 1e-12 * b;
  // A Newton step this short leaves the next iterate within about its
  // square of the root (quadratic convergence): close enough to try the
  // point just past it. Near a double root, where Newton is slow, the try
  // fails and the bracket moves on.
  const double near = 1e-7 * b;
  double lo = a, hi = b;
  double tau =
      start.value > 0.0 ? a + (b - a) * start.value / (start.value - end.value) : 0.5 * (a + b);
  for (int i = 0; i < 60 && hi - lo > resolution; ++i) {
    const double value = s * at(v, tau);
    (value >= 0.0 ? lo : hi) = tau;
    const double d = s * slope_at(v, tau);
    const double next = d != 0.0 ? tau - value / d : 0.5 * (lo + hi);
    if (std::abs(next - tau) <= near) {
      const double past = next + 0.5 * resolution;
      if (past > lo && past < hi) {
        if (s * at(v, past) < 0.0) return past;
        lo = past;
      }
    }
    tau = next > lo && next < hi ? next : 0.5 * (lo + hi);
  }
  return hi;
}

/// Its second derivative at tau.
double curvature_at(const Coefficients& c, double tau) {
  double sum = kOrder * (kOrder - 1) * c[kOrder];
  for (int k = kOrder - 1; k >= 2; --k)
    sum = sum * tau + k * (k - 1) * c[static_cast<std::size_t>(k)];
  return sum;
}

/// The minimum of s*v in (a, b), given s*v' < 0 at a and > 0 at b: Newton
/// on v', kept inside the bracket by bisection.
double dip(const Coefficients& v, double s, double a, double b) {
  double lo = a, hi = b, tau = 0.5 * (a + b);
  const double resolution = 1e-12 * b;
  for (int i = 0; i < 60 && hi - lo > resolution; ++i) {
    const double d = s * slope_at(v, tau);
    (d < 0.0 ? lo : hi) = tau;
    const double c = s * curvature_at(v, tau);
    const double next = c > 0.0 ? tau - d / c : 0.5 * (lo + hi);
    if (d == 0.0 || std::abs(next - tau) <= resolution) return std::clamp(next, lo, hi);
    tau = next > lo && next < hi ? next : 0.5 * (lo + hi);
  }
  return tau;
}

}  // namespace

double first_zero(const Coefficients& v, double s, double h) {
  // s*v and its slope at each end, each evaluated once and carried on.
  double a = 0.0;
  End start{s * v[0], s * v[1]};
  for (const double b : {0.5 * h, h}) {
    const End end{s * at(v, b), s * slope_at(v, b)};
    if (start.slope < 0.0 && end.slope > 0.0) {
      const double m = dip(v, s, a, b);
      if (const double value_m = s * at(v, m); value_m < 0.0) {
        return first_root(v, s, a, m, start, {value_m, 0.0});  // v' = 0 at the dip
      }
    }
    if (end.value < 0.0) return first_root(v, s, a, b, start, end);
    a = b;
    start = end;
  }
  return h;
}

double sliding_sign(const Coefficients& v) {
  for (const double c : v) {
    if (c != 0.0) return c > 0.0 ? 1.0 : -1.0;
  }
  return 1.0;
}

}  // namespace piezo::model::hybrid
