#include "piezo/model/lugre_taylor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "piezo/model/motor.hpp"
#include "piezo/model/step_control.hpp"

namespace piezo::model {
namespace {

/// Order of the series: orders 12-13 missed near-grazing reversals at 5 Hz
/// in the prototype the issue measured.
constexpr int kOrder = 14;
using Coefficients = std::array<double, kOrder + 1>;

/// Horner: the series at tau.
double at(const Coefficients& c, double tau) {
  double sum = c[kOrder];
  for (int k = kOrder - 1; k >= 0; --k) sum = sum * tau + c[static_cast<std::size_t>(k)];
  return sum;
}

/// Its derivative at tau.
double slope_at(const Coefficients& c, double tau) {
  double sum = kOrder * c[kOrder];
  for (int k = kOrder - 1; k >= 1; --k) sum = sum * tau + k * c[static_cast<std::size_t>(k)];
  return sum;
}

/// The series of the five states and of v about one point.
struct Expansion {
  std::array<Coefficients, 5> y;  ///< x, x', theta, theta', z
  Coefficients v;                 ///< x' - r theta'

  [[nodiscard]] LuGreState state(double tau) const {
    LuGreState out{};
    for (std::size_t i = 0; i < 5; ++i) out[i] = at(y[i], tau);
    return out;
  }
};

class SeriesMotor {
 public:
  explicit SeriesMotor(const MotorParameters& p)
      : p_(p),
        kappa_(p.sigma0 / p.F_c()),
        r_over_J_(p.r / p.J),
        inv_M_(1.0 / p.M),
        K_d_e_(p.K * p.d_e) {}

  /// The series about state y0, with V = V0 + slope*tau and s = sgn(v).
  void expand(const LuGreState& y0, double V0, double slope, double s, Expansion& e) const {
    auto& [x, X, th, W, z] = e.y;
    x[0] = y0[kX];
    X[0] = y0[kXDot];
    th[0] = y0[kTheta];
    W[0] = y0[kThetaDot];
    z[0] = y0[kZ];
    const double sk = s * kappa_;
    for (int k = 0; k < kOrder; ++k) {
      const auto K = static_cast<std::size_t>(k);
      e.v[K] = X[K] - p_.r * W[K];
      double vz = 0.0;
      for (std::size_t j = 0; j <= K; ++j) vz += e.v[j] * z[K - j];
      const double zd = e.v[K] - sk * vz;
      const double F = p_.sigma0 * z[K] + p_.sigma1 * zd + p_.sigma2 * e.v[K];
      const double Vk = k == 0 ? V0 : (k == 1 ? slope : 0.0);
      const double Xd = (K_d_e_ * Vk - p_.C * X[K] - p_.K * x[K] - F) * inv_M_;
      const double inv = 1.0 / (k + 1);
      x[K + 1] = X[K] * inv;
      X[K + 1] = Xd * inv;
      th[K + 1] = W[K] * inv;
      W[K + 1] = r_over_J_ * F * inv;
      z[K + 1] = zd * inv;
    }
    e.v[kOrder] = X[kOrder] - p_.r * W[kOrder];
  }

 private:
  MotorParameters p_;
  double kappa_, r_over_J_, inv_M_, K_d_e_;
};

/// The first root of s*v in (a, b], given s*v(a) >= 0 > s*v(b): Newton
/// from the bracket, kept inside it by bisection.
double first_root(const Coefficients& v, double s, double a, double b) {
  double lo = a, hi = b, tau = 0.5 * (a + b);
  for (int i = 0; i < 60 && hi - lo > 1e-16 * std::max(1.0, hi); ++i) {
    const double value = s * at(v, tau);
    (value >= 0.0 ? lo : hi) = tau;
    const double d = s * slope_at(v, tau);
    const double next = d != 0.0 ? tau - value / d : 0.5 * (lo + hi);
    tau = next > lo && next < hi ? next : 0.5 * (lo + hi);
  }
  return hi;
}

/// The minimum of s*v in (a, b), given s*v' < 0 at a and > 0 at b.
double dip(const Coefficients& v, double s, double a, double b) {
  double lo = a, hi = b;
  for (int i = 0; i < 60 && hi - lo > 1e-16 * std::max(1.0, hi); ++i) {
    const double mid = 0.5 * (lo + hi);
    (s * slope_at(v, mid) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// Where s*v first turns negative in (0, h] (h when it does not): a sign
/// change at h/2 or h, or a dip of s*v below zero inside a half step (a
/// half step holds at most one extremum of v).
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

/// The sign the contact slides with from a point where v may be zero: that
/// of v, else of its first nonzero derivative there.
double sliding_sign(const Coefficients& v) {
  for (const double c : v) {
    if (c != 0.0) return c > 0.0 ? 1.0 : -1.0;
  }
  return 1.0;
}

}  // namespace

Trajectory simulate_lugre_taylor(const MotorParameters& p, const Excitation& drive,
                                 std::span<const double> times,
                                 const IntegratorSettings& settings) {
  Trajectory out;
  out.stats.integrator = Integrator::taylor;
  if (times.empty()) return out;
  if (times.front() < 0.0 || !std::is_sorted(times.begin(), times.end())) {
    throw std::invalid_argument("sample times must be non-negative and non-decreasing");
  }
  const SeriesMotor series(p);
  const LuGreMotor motor(p);
  const LuGreState scale = state_scale<5>(p);
  // The per-step error against each state's scale: the truncation error of
  // a step is about its last term, so that term is held to this.
  const double tolerance = 1e-1 * settings.tolerance;
  const double h_max = 4.0 / std::sqrt(p.K / p.M);
  auto emit = [&](double t, const LuGreState& y) {
    out.t.push_back(t);
    out.V.push_back(drive.voltage(t));
    out.x.push_back(y[kX]);
    out.x_dot.push_back(y[kXDot]);
    out.theta.push_back(y[kTheta]);
    out.theta_dot.push_back(y[kThetaDot]);
    out.z.push_back(y[kZ]);
    out.F_f.push_back(motor.friction(y).force);
    if (settings.progress && out.t.size() % 10000 == 0) settings.progress(t);
  };

  std::size_t next = 0;
  LuGreState y{};
  while (next < times.size() && times[next] <= 0.0) emit(times[next++], y);
  const double t_end = times.back();
  double t = 0.0;
  double s = 0.0;  ///< the sliding sign; 0: to be found at the next step
  Expansion e;
  while (next < times.size()) {
    const LinearPiece piece = drive.piece(t);
    const double corner = std::min(drive.next_breakpoint(t), t_end);
    const double V0 = piece.at(t);
    if (s == 0.0) {
      series.expand(y, V0, piece.slope, 1.0, e);
      s = sliding_sign(e.v);
    }
    series.expand(y, V0, piece.slope, s, e);
    // A contact that slides the other way than s says (v crossed zero by a
    // rounding at the last event): the sign it really has.
    if (s * e.v[0] < 0.0 && s * e.v[1] <= 0.0) {
      s = -s;
      series.expand(y, V0, piece.slope, s, e);
    }
    // The step from the last two orders' decay, against each state's scale.
    double h = std::min(h_max, corner - t);
    double last = 0.0, before = 0.0;  // the largest scaled coefficient of each order
    for (std::size_t i = 0; i < 5; ++i) {
      last = std::max(last, std::abs(e.y[i][kOrder]) / scale[i]);
      before = std::max(before, std::abs(e.y[i][kOrder - 1]) / scale[i]);
    }
    if (last > 0.0) h = std::min(h, std::pow(tolerance / last, 1.0 / kOrder));
    if (before > 0.0) h = std::min(h, std::pow(tolerance / before, 1.0 / (kOrder - 1)));
    h = std::max(h, 1e-14 * std::max(1.0, t));
    const double tau = first_zero(e.v, s, h);
    const bool reversal = tau < h;
    const double t1 = tau == corner - t ? corner : t + tau;
    while (next < times.size() && times[next] <= t1) {
      emit(times[next], e.state(times[next] - t));
      ++next;
    }
    y = e.state(tau);
    ++out.stats.steps;
    out.stats.rhs_evaluations += kOrder;
    if (reversal) {
      // A zero of v: the contact slides the way v' points there.
      ++out.stats.mode_switches;
      s = slope_at(e.v, tau) >= 0.0 ? 1.0 : -1.0;
    }
    t = t1;
    if (t >= t_end) {
      while (next < times.size()) emit(times[next++], y);
    }
  }
  return out;
}

}  // namespace piezo::model
