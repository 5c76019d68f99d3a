#include "piezo/model/coulomb_closed_form.hpp"

#include <algorithm>
#include <boost/math/tools/roots.hpp>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "piezo/model/motor.hpp"

namespace piezo::model {
namespace {

using Complex = std::complex<double>;

/// A mode shorter than this is rounding at a grazing switch [s].
constexpr double kGrazing = 1e-12;

/// Chattering contact: this many switches in a row, each after a mode
/// shorter than kChatter, are a Zeno sequence of stick and slip whose
/// limit is sticking (event-driven friction solvers take it so). The
/// contact is then held stuck for a stretch that starts at kFirstHold and
/// doubles while the chatter resumes right after it, up to kLongestHold.
constexpr int kChatterSwitches = 4;
constexpr double kChatter = 1e-9;
constexpr double kFirstHold = 1e-9;
constexpr double kLongestHold = 1e-6;

/// The rotor's inertia seen at the contact point: J / r^2.
double reflected_mass(const MotorParameters& p) {
  return p.J / (p.r * p.r);
}

/// Squared damped ringing frequency of the stator carrying `mass`.
double damped_frequency_squared(const MotorParameters& p, double mass) {
  const double alpha = p.C / (2.0 * mass);
  return p.K / mass - alpha * alpha;
}

/// One stretch of constant contact mode and linear drive voltage, starting
/// at absolute time t_s in state y0. With tau = t - t_s, the stator is
///   x(tau) = p0 + p1 tau + Re(c e^(lambda tau))
/// (a ramp particular solution plus the damped ringing), and the rotor
/// follows it (stick) or turns under the constant torque r F_c (slip).
class Piece {
 public:
  /// `from_rest_relative`: the piece starts at a switch, where v = 0 exactly.
  Piece(const MotorParameters& p, ContactMode mode, const LinearPiece& V, double t_s,
        const CoulombState& y0, bool from_rest_relative)
      : p_(p), mode_(mode), y0_(y0), m_r_(reflected_mass(p)) {
    v0_ = from_rest_relative ? 0.0 : y0[kXDot] - p.r * y0[kThetaDot];
    const bool stick = mode == ContactMode::stick;
    const double mass = stick ? p.M + m_r_ : p.M;
    direction_ = mode == ContactMode::slip_forward    ? 1.0
                 : mode == ContactMode::slip_backward ? -1.0
                                                      : 0.0;
    // M x'' + C x' + K x = K d_e (V_a + b tau) - s F_c.
    p1_ = p.d_e * V.slope;
    p0_ = (p.K * p.d_e * V.at(t_s) - direction_ * p.F_c() - p.C * p1_) / p.K;
    alpha_ = p.C / (2.0 * mass);
    omega_d_ = std::sqrt(damped_frequency_squared(p, mass));
    omega_n_ = std::sqrt(p.K / mass);
    const Complex lambda(-alpha_, omega_d_);
    const double u0 = y0[kX] - p0_;
    const double u0_rate = y0[kXDot] - p1_;
    c_[0] = Complex(u0, -(u0_rate + alpha_ * u0) / omega_d_);
    for (int k = 1; k < 5; ++k) c_[k] = c_[k - 1] * lambda;
    rotor_acceleration_ = p.r * p.F_c() / p.J;
  }

  [[nodiscard]] CoulombState state(double tau) const {
    const Complex e = ringing(tau);
    CoulombState y;
    y[kX] = p0_ + p1_ * tau + (c_[0] * e).real();
    y[kXDot] = p1_ + (c_[1] * e).real();
    if (mode_ == ContactMode::stick) {
      y[kTheta] = y0_[kTheta] + (y[kX] - y0_[kX]) / p_.r;
      y[kThetaDot] = y[kXDot] / p_.r;
    } else {
      const double a = direction_ * rotor_acceleration_;
      y[kTheta] = y0_[kTheta] + y0_[kThetaDot] * tau + 0.5 * a * tau * tau;
      y[kThetaDot] = y0_[kThetaDot] + a * tau;
    }
    return y;
  }

  [[nodiscard]] double friction(double tau) const {
    return mode_ == ContactMode::stick ? m_r_ * (c_[2] * ringing(tau)).real()
                                       : direction_ * p_.F_c();
  }

  /// The first tau in (0, tau_end] where the contact mode ends, if any.
  [[nodiscard]] std::optional<double> first_switch(double tau_end) const {
    // Walk forward over intervals that are proven free of a switch: by a
    // second-order Taylor bound (value, rate, curvature, and a bound on the
    // ringing's third derivative) that keeps g inside the mode, or because
    // g is monotone there and its end value is still inside. Each interval
    // is as long as one of the two proofs allows, so no evaluation is
    // wasted; the first interval whose monotone end lies outside brackets
    // the switch, solved to full precision.
    double a = 0.0;
    Value va = at(a);
    while (a < tau_end) {
      const double cap = tau_end - a;
      const double jerk = jerk_bound(va);
      double h_bound = envelope_interval(a, va, cap);
      if (h_bound < cap) {
        h_bound =
            std::max(h_bound, longest(cap, [&](double h) { return stays_in_mode(va, jerk, h); }));
      }
      const double h_monotone = std::min(cap, monotone_interval(va, jerk));
      const double h = std::max({h_bound, h_monotone, std::min(kSmallestInterval, cap)});
      const double b = a + h;
      const Value vb = at(b);
      if (h > h_bound && !in_mode(vb.g)) return solve(a, va, b, vb);
      a = b;
      va = vb;
    }
    return std::nullopt;
  }

  [[nodiscard]] std::uint64_t evaluations() const { return evaluations_; }

 private:
  static constexpr double kSmallestInterval = 1e-13;

  [[nodiscard]] Complex ringing(double tau) const {
    ++evaluations_;
    return std::polar(std::exp(-alpha_ * tau), omega_d_ * tau);
  }

  /// The switch quantity g at one time: slip, s v (the mode holds while
  /// positive); stick, the force that holds rotor and stator together
  /// (holds within +-F_c). With its rate and the ringing's envelope there.
  struct Value {
    double g, rate, curvature, envelope;
  };

  // A slip that starts at a switch begins at v = 0 with a rate that can be
  // a millionth of the stator's acceleration, so v is summed from its
  // change since the start, not from the two large velocities.
  [[nodiscard]] Value at(double tau) const {
    ++evaluations_;
    // One expm1 and the half angle's sine and cosine give e^(lambda tau)
    // and e^(lambda tau) - 1, the latter without cancellation.
    const double decay_change = std::expm1(-alpha_ * tau);
    const double decay = 1.0 + decay_change;
    const double half_sin = std::sin(0.5 * omega_d_ * tau);
    const double half_cos = std::cos(0.5 * omega_d_ * tau);
    const double cos_change = -2.0 * half_sin * half_sin;
    const double c = 1.0 + cos_change, s = 2.0 * half_sin * half_cos;
    const Complex e(decay * c, decay * s);
    if (mode_ == ContactMode::stick) {
      return {m_r_ * (c_[2] * e).real(), m_r_ * (c_[3] * e).real(), m_r_ * (c_[4] * e).real(),
              decay};
    }
    const Complex change(decay_change * c + cos_change, decay * s);
    const double slowing = p_.r * rotor_acceleration_;
    return {direction_ * (v0_ + (c_[1] * change).real()) - slowing * tau,
            direction_ * (c_[2] * e).real() - slowing, direction_ * (c_[3] * e).real(), decay};
  }

  /// A bound on |d^3 g / d tau^3| from this point on: the ringing's
  /// envelope decays (1 % over, so rounding cannot undo a proof).
  [[nodiscard]] double jerk_bound(const Value& v) const {
    const double amplitude = 1.01 * std::abs(c_[0]) * v.envelope;
    const double w4 = omega_n_ * omega_n_ * omega_n_ * omega_n_;
    return mode_ == ContactMode::stick ? m_r_ * amplitude * w4 * omega_n_ : amplitude * w4;
  }

  /// How long the ringing's envelope alone keeps the mode from tau = a on:
  /// stick holds for good once the holding force's envelope is within F_c;
  /// slip holds while its steady part, falling at the constant relative
  /// deceleration, stays above the ringing's envelope.
  [[nodiscard]] double envelope_interval(double a, const Value& v, double cap) const {
    const double ringing = std::abs(c_[0]) * v.envelope;
    if (mode_ == ContactMode::stick) {
      return m_r_ * ringing * omega_n_ * omega_n_ <= p_.F_c() ? cap : 0.0;
    }
    const double slowing = p_.r * rotor_acceleration_;
    const double steady = direction_ * (v0_ - c_[1].real()) - slowing * a;
    const double margin = steady - ringing * omega_n_;
    if (margin <= 0.0) return 0.0;
    return slowing > 0.0 ? std::min(cap, 0.999 * margin / slowing) : cap;
  }

  /// Taylor's theorem to second order: over [a, a + h], g lies within the
  /// range of g + g' x + g'' x^2 / 2 widened by jerk h^3 / 6.
  [[nodiscard]] bool stays_in_mode(const Value& v, double jerk, double h) const {
    auto q = [&](double x) { return v.g + x * (v.rate + 0.5 * x * v.curvature); };
    double lo = std::min(v.g, q(h)), hi = std::max(v.g, q(h));
    if (v.curvature != 0.0) {
      const double vertex = -v.rate / v.curvature;
      if (vertex > 0.0 && vertex < h) {
        lo = std::min(lo, q(vertex));
        hi = std::max(hi, q(vertex));
      }
    }
    const double slack = jerk * h * h * h / 6.0;
    lo -= slack;
    hi += slack;
    return mode_ == ContactMode::stick ? lo >= -p_.F_c() && hi <= p_.F_c() : lo > 0.0;
  }

  /// How long g' keeps its sign: g' + g'' x stays clear of jerk x^2 / 2.
  [[nodiscard]] static double monotone_interval(const Value& v, double jerk) {
    const double rate = std::abs(v.rate);
    const double towards = v.rate > 0.0 ? v.curvature : -v.curvature;  // d|g'|/dx at a
    if (rate == 0.0) return 0.0;
    if (jerk <= 0.0) {
      return towards >= 0.0 ? std::numeric_limits<double>::infinity() : 0.999 * rate / -towards;
    }
    // Root of rate + min(0, towards) x - jerk x^2 / 2.
    const double slope = std::min(0.0, towards);
    return 0.999 * (slope + std::sqrt(slope * slope + 2.0 * jerk * rate)) / jerk;
  }

  /// About the longest h in (0, cap] for which `holds` (true up to some h,
  /// false beyond), or 0: quartered down from cap, then bisected to within
  /// a tenth. Arithmetic only, no evaluation of g.
  template <class Holds>
  [[nodiscard]] static double longest(double cap, Holds&& holds) {
    if (holds(cap)) return cap;
    double h = cap;
    while (h > kSmallestInterval && !holds(h)) h *= 0.25;
    if (h <= kSmallestInterval) return 0.0;
    double lo = h, hi = std::min(4.0 * h, cap);
    while (hi - lo > 0.1 * lo) {
      const double mid = 0.5 * (lo + hi);
      (holds(mid) ? lo : hi) = mid;
    }
    return lo;
  }

  [[nodiscard]] bool in_mode(double value) const {
    return mode_ == ContactMode::stick ? std::abs(value) <= p_.F_c() : value > 0.0;
  }

  /// The switch inside [a, b], where g is monotone and leaves the mode at b.
  [[nodiscard]] double solve(double a, const Value& va, double b, const Value& vb) const {
    const double level = mode_ == ContactMode::stick ? std::copysign(p_.F_c(), vb.g) : 0.0;
    const double fa = va.g - level, fb = vb.g - level;
    // g is monotone on [a, b] (first_switch proved it): Newton's method,
    // kept inside the bracket, from the secant's guess.
    const double guess = fa == fb ? b : a + (b - a) * fa / (fa - fb);
    std::uintmax_t iterations = 50;
    return boost::math::tools::newton_raphson_iterate(
        [&](double t) {
          const Value v = at(t);
          return std::make_pair(v.g - level, v.rate);
        },
        std::clamp(guess, a, b), a, b, std::numeric_limits<double>::digits - 4, iterations);
  }

  const MotorParameters& p_;
  ContactMode mode_;
  CoulombState y0_;
  double m_r_;
  double direction_ = 0.0;
  double v0_ = 0.0;  ///< sliding velocity at the start
  double p0_ = 0.0, p1_ = 0.0;
  double alpha_ = 0.0, omega_d_ = 0.0, omega_n_ = 0.0;
  double rotor_acceleration_ = 0.0;
  Complex c_[5];  ///< c lambda^k: the ringing's k-th derivative is Re(c_[k] e^(lambda tau))
  mutable std::uint64_t evaluations_ = 0;
};

}  // namespace

bool coulomb_closed_form_applies(const MotorParameters& p) {
  return damped_frequency_squared(p, p.M) > 0.0 &&
         damped_frequency_squared(p, p.M + reflected_mass(p)) > 0.0;
}

Trajectory simulate_coulomb_closed_form(const MotorParameters& p, const Excitation& drive,
                                        std::span<const double> times,
                                        const IntegratorSettings& settings, Trajectory storage) {
  if (!coulomb_closed_form_applies(p)) {
    throw std::invalid_argument(
        "integrator closed_form: the stator must ring (C < 2 sqrt(K M)); use dopri5");
  }
  Trajectory out = std::move(storage);
  out.restart(settings.columns);
  out.stats.integrator = Integrator::closed_form;
  if (times.empty()) return out;
  if (times.front() < 0.0 || !std::is_sorted(times.begin(), times.end())) {
    throw std::invalid_argument("sample times must be non-negative and non-decreasing");
  }
  const std::size_t n = times.size();
  out.reserve(n);
  auto emit = [&](double t, const CoulombState& y, double F_f) {
    out.append(t, drive.voltage(t), y, F_f);
  };

  CoulombState y{};
  ContactMode mode = ContactMode::stick;  // from rest at 0 V
  std::size_t next = 0;
  while (next < n && times[next] <= 0.0) emit(times[next++], y, 0.0);
  const double t_end = times.back();
  double t = 0.0;
  int chatter = 0;  // switches in a row after modes shorter than kChatter
  double hold = kFirstHold;
  bool at_switch = true;
  while (next < n) {
    const double segment_end = std::min(drive.next_breakpoint(t), t_end);
    if (settings.progress) settings.progress(t);
    if (chatter >= kChatterSwitches) {
      // The limit of the chatter: stuck, without the switch test, for a
      // stretch; the next piece then decides afresh.
      const double t_stop = std::min(t + hold, segment_end);
      Piece stuck(p, ContactMode::stick, drive.piece(t), t, y, true);
      while (next < n && times[next] <= t_stop) {
        emit(times[next], stuck.state(times[next] - t), stuck.friction(times[next] - t));
        ++next;
      }
      y = stuck.state(t_stop - t);
      ++out.stats.steps;
      ++out.stats.chatter_holds;
      out.stats.rhs_evaluations += stuck.evaluations();
      mode = ContactMode::stick;
      at_switch = true;
      chatter = 0;
      hold = std::min(2.0 * hold, kLongestHold);
      t = t_stop;
      continue;
    }
    Piece piece(p, mode, drive.piece(t), t, y, at_switch);
    const std::optional<double> tau_switch = piece.first_switch(segment_end - t);
    const double t_stop = tau_switch ? t + *tau_switch : segment_end;
    while (next < n && times[next] <= t_stop) {
      emit(times[next], piece.state(times[next] - t), piece.friction(times[next] - t));
      ++next;
    }
    y = piece.state(t_stop - t);
    ++out.stats.steps;
    out.stats.rhs_evaluations += piece.evaluations();
    if (tau_switch) {
      // A mode that lasted under a picosecond is rounding at a grazing
      // switch (v or the holding force touching its limit): the switches
      // into and out of it are one.
      if (at_switch && *tau_switch < kGrazing && !out.switch_times.empty()) {
        out.switch_times.back() = t_stop;
      } else {
        ++out.stats.mode_switches;
        out.switch_times.push_back(t_stop);
      }
      if (mode == ContactMode::stick) {
        // The holding force reached F_c: slip the way it points.
        mode = piece.friction(t_stop - t) > 0.0 ? ContactMode::slip_forward
                                                : ContactMode::slip_backward;
      } else {
        y[kThetaDot] = y[kXDot] / p.r;  // the slip ended at v = 0
        mode = coulomb_mode_after_slip(p, drive.voltage(t_stop), y);
      }
      chatter = *tau_switch < kChatter ? chatter + 1 : 0;
    } else {
      chatter = 0;
    }
    if (chatter == 0 && t_stop - t >= kChatter) hold = kFirstHold;
    at_switch = tau_switch.has_value();
    t = t_stop;
  }
  return out;
}

}  // namespace piezo::model
