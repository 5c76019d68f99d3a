#include "piezo/model/hybrid/series.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::model::hybrid {

double at(const Coefficients& c, double tau) {
  double sum = c[kOrder];
  for (int k = kOrder - 1; k >= 0; --k) sum = sum * tau + c[static_cast<std::size_t>(k)];
  return sum;
}

double slope_at(const Coefficients& c, double tau) {
  double sum = kOrder * c[kOrder];
  for (int k = kOrder - 1; k >= 1; --k) sum = sum * tau + k * c[static_cast<std::size_t>(k)];
  return sum;
}

LuGreState Expansion::state(double tau) const {
  LuGreState out{};
  for (std::size_t i = 0; i < 5; ++i) out[i] = at(y[i], tau);
  return out;
}

SeriesMotor::SeriesMotor(const MotorParameters& p)
    : p_(p),
      kappa_(p.sigma0 / p.F_c()),
      r_over_J_(p.r / p.J),
      inv_M_(1.0 / p.M),
      K_d_e_(p.K * p.d_e) {}

void SeriesMotor::expand(const LuGreState& y0, double V0, double slope, double s, bool saturated,
                         Expansion& e) const {
  auto& [x, X, th, W, z] = e.y;
  x[0] = y0[kX];
  X[0] = y0[kXDot];
  th[0] = y0[kTheta];
  W[0] = y0[kThetaDot];
  z[0] = y0[kZ];
  const double sk = s * kappa_;
  // z's coefficients also in reverse, so that the Cauchy product of v and z
  // runs over both in the same direction (a dot product the compiler can
  // vectorise).
  Coefficients z_reversed{};
  z_reversed[kOrder] = z[0];
  for (int k = 0; k < kOrder; ++k) {
    const auto K = static_cast<std::size_t>(k);
    e.v[K] = X[K] - p_.r * W[K];
    double vz = 0.0;
    const double* zr = z_reversed.data() + (kOrder - K);
    for (std::size_t j = 0; j <= K; ++j) vz += e.v[j] * zr[j];
    const double zd = saturated ? 0.0 : e.v[K] - sk * vz;
    const double F = p_.sigma0 * z[K] + p_.sigma1 * zd + p_.sigma2 * e.v[K];
    const double Vk = k == 0 ? V0 : (k == 1 ? slope : 0.0);
    const double Xd = (K_d_e_ * Vk - p_.C * X[K] - p_.K * x[K] - F) * inv_M_;
    const double inv = 1.0 / (k + 1);
    x[K + 1] = X[K] * inv;
    X[K + 1] = Xd * inv;
    th[K + 1] = W[K] * inv;
    W[K + 1] = r_over_J_ * F * inv;
    z[K + 1] = zd * inv;
    z_reversed[kOrder - K - 1] = z[K + 1];
  }
  e.v[kOrder] = X[kOrder] - p_.r * W[kOrder];
}

double allowed_step(const Expansion& e, const LuGreState& scale, double tolerance, double h_max) {
  double h = h_max;
  double last = 0.0, before = 0.0;  // the largest scaled coefficient of each order
  for (std::size_t i = 0; i < 5; ++i) {
    last = std::max(last, std::abs(e.y[i][kOrder]) / scale[i]);
    before = std::max(before, std::abs(e.y[i][kOrder - 1]) / scale[i]);
  }
  if (last > 0.0) h = std::min(h, std::pow(tolerance / last, 1.0 / kOrder));
  if (before > 0.0) h = std::min(h, std::pow(tolerance / before, 1.0 / (kOrder - 1)));
  return h;
}

namespace {

/// The first root of s*v in (a, b], given s*v(a) >= 0 > s*v(b): Newton
/// from the bracket, kept inside it by bisection.
/// The first root of s*v in (a, b], given s*v(a) >= 0 > s*v(b): Newton
/// from the chord (the midpoint when v(a) = 0, a reversal just passed),
/// kept inside the bracket by bisection. Returns a point where s*v < 0, the
/// first past the root to 1e-12 of the step, so that the step ends with the
/// contact's new sign.
double first_root(const Coefficients& v, double s, double a, double b) {
  const double resolution = 1e-12 * b;
  const double va = s * at(v, a), vb = s * at(v, b);
  double lo = a, hi = b;
  double tau = va > 0.0 ? a + (b - a) * va / (va - vb) : 0.5 * (a + b);
  for (int i = 0; i < 60 && hi - lo > resolution; ++i) {
    const double value = s * at(v, tau);
    (value >= 0.0 ? lo : hi) = tau;
    const double d = s * slope_at(v, tau);
    const double next = d != 0.0 ? tau - value / d : 0.5 * (lo + hi);
    if (std::abs(next - tau) <= resolution) {
      if (value < 0.0) return tau;
      // Converged from before the root: one resolution further has turned.
      tau = std::min(tau + resolution, 0.5 * (lo + hi));
      continue;
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
  double a = 0.0;
  for (const double b : {0.5 * h, h}) {
    if (s * slope_at(v, a) < 0.0 && s * slope_at(v, b) > 0.0) {
      const double m = dip(v, s, a, b);
      if (s * at(v, m) < 0.0) return first_root(v, s, a, m);
    }
    if (s * at(v, b) < 0.0) return first_root(v, s, a, b);
    a = b;
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
