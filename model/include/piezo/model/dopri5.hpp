#pragma once
/// @file
/// Dormand-Prince 5(4) with Hairer's 4th-order dense output, specialised for
/// small fixed-size states held in std::array.
///
/// Why not Boost.Odeint's runge_kutta_dopri5: on this 5-state motor the
/// generic algebra and the state scaling it needs (one tolerance for all
/// components) cost about twice the model evaluation itself, measured with
/// callgrind; the simulation is stability-bound at ~2/omega_n per step, so
/// per-step cost is what decides throughput. Here tolerances are per
/// component and a step is straight-line code the compiler unrolls.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace piezo::model {

template <std::size_t N>
class Dopri5 {
 public:
  using State = std::array<double, N>;

  /// @param rtol relative tolerance, @param atol absolute tolerance per component,
  /// @param max_step largest step the controller may propose [s].
  Dopri5(double rtol, const State& atol, double max_step)
      : rtol_(rtol), atol_(atol), max_step_(max_step) {}

  /// Starts (or restarts, after a discontinuity) at (t, y) with a first trial step h.
  template <class Rhs>
  void initialize(Rhs&& rhs, double t, const State& y, double h) {
    t_ = t;
    y_ = y;
    h_ = std::min(h, max_step_);
    rhs(y_, k1_, t_);
    ++evaluations_;
  }

  /// Takes one accepted step of at most `h_limit` (retrying smaller on
  /// rejection). Afterwards [previous_time(), time()] is the step's span.
  template <class Rhs>
  void step(Rhs&& rhs, double h_limit) {
    for (;;) {
      const double h = std::min(h_, h_limit);
      State tmp, k2, y_new;
      State &k3 = k3_, &k4 = k4_, &k5 = k5_, &k6 = k6_, &k7 = k7_;
      for (std::size_t i = 0; i < N; ++i) tmp[i] = y_[i] + h * (a21 * k1_[i]);
      rhs(tmp, k2, t_ + c2 * h);
      for (std::size_t i = 0; i < N; ++i) tmp[i] = y_[i] + h * (a31 * k1_[i] + a32 * k2[i]);
      rhs(tmp, k3, t_ + c3 * h);
      for (std::size_t i = 0; i < N; ++i)
        tmp[i] = y_[i] + h * (a41 * k1_[i] + a42 * k2[i] + a43 * k3[i]);
      rhs(tmp, k4, t_ + c4 * h);
      for (std::size_t i = 0; i < N; ++i)
        tmp[i] = y_[i] + h * (a51 * k1_[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
      rhs(tmp, k5, t_ + c5 * h);
      for (std::size_t i = 0; i < N; ++i)
        tmp[i] = y_[i] + h * (a61 * k1_[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
      rhs(tmp, k6, t_ + h);
      for (std::size_t i = 0; i < N; ++i)
        y_new[i] =
            y_[i] + h * (a71 * k1_[i] + a73 * k3[i] + a74 * k4[i] + a75 * k5[i] + a76 * k6[i]);
      rhs(y_new, k7, t_ + h);
      evaluations_ += 6;

      double sum = 0.0;
      for (std::size_t i = 0; i < N; ++i) {
        const double err =
            h * (e1 * k1_[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i]);
        const double sc = atol_[i] + rtol_ * std::max(std::abs(y_[i]), std::abs(y_new[i]));
        const double ratio = err / sc;
        sum += ratio * ratio;
      }
      const double err_squared = sum / N;  // RMS norm, squared: sqrt only when needed
      if (err_squared <= 1.0) {
        // Dense-output coefficients are worked out only when asked for
        // (dense()): most steps of a long run are never sampled.
        y_old_ = y_;
        k1_old_ = k1_;
        t_old_ = t_;
        h_old_ = h;
        t_ += h;
        y_ = y_new;
        k1_ = k7;  // first same as last
        h_ = next_step(h, err_squared);
        ++steps_;
        return;
      }
      h_ = next_step(h, err_squared);
    }
  }

  /// State at t inside the last step, from the 4th-order continuous extension.
  /// Valid until the next step().
  [[nodiscard]] State dense(double t) const {
    const double h = h_old_;
    const double s = (t - t_old_) / h;
    const double s1 = 1.0 - s;
    State out;
    for (std::size_t i = 0; i < N; ++i) {
      const double dy = y_[i] - y_old_[i];
      const double bspl = h * k1_old_[i] - dy;
      const double r4 = dy - h * k7_[i] - bspl;
      const double r5 = h * (d1 * k1_old_[i] + d3 * k3_[i] + d4 * k4_[i] + d5 * k5_[i] +
                             d6 * k6_[i] + d7 * k7_[i]);
      out[i] = y_old_[i] + s * (dy + s1 * (bspl + s * (r4 + s1 * r5)));
    }
    return out;
  }

  [[nodiscard]] double time() const { return t_; }
  [[nodiscard]] double previous_time() const { return t_old_; }
  [[nodiscard]] const State& state() const { return y_; }
  [[nodiscard]] double proposed_step() const { return h_; }
  [[nodiscard]] std::size_t steps() const { return steps_; }
  [[nodiscard]] std::size_t evaluations() const { return evaluations_; }

 private:
  /// Classic controller: h * 0.9 * err^(-1/5), growth within [0.2, 5], at
  /// most max_step. The stability-bound motor mostly sits at max_step, where
  /// the test below spares the pow() that would otherwise cost as much as a
  /// model evaluation.
  [[nodiscard]] double next_step(double h, double err_squared) const {
    const double q = 0.9 * h / max_step_;
    const double q5 = q * q * q * q * q;
    if (q >= 0.18 && err_squared <= q5 * q5) return max_step_;  // growth cap 5 respected
    const double err = std::sqrt(err_squared);
    const double factor = err == 0.0 ? 5.0 : std::clamp(0.9 * std::pow(err, -0.2), 0.2, 5.0);
    return std::min(h * (err <= 1.0 ? factor : std::min(1.0, factor)), max_step_);
  }

  static constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  static constexpr double a21 = 1.0 / 5;
  static constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  static constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  static constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                          a54 = -212.0 / 729;
  static constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247,
                          a64 = 49.0 / 176, a65 = -5103.0 / 18656;
  static constexpr double a71 = 35.0 / 384, a73 = 500.0 / 1113, a74 = 125.0 / 192,
                          a75 = -2187.0 / 6784, a76 = 11.0 / 84;
  static constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920,
                          e5 = -17253.0 / 339200, e6 = 22.0 / 525, e7 = -1.0 / 40;
  // Hairer & Wanner, dopri5.f: coefficients of the continuous extension.
  static constexpr double d1 = -12715105075.0 / 11282082432.0, d3 = 87487479700.0 / 32700410799.0,
                          d4 = -10690763975.0 / 1880347072.0, d5 = 701980252875.0 / 199316789632.0,
                          d6 = -1453857185.0 / 822651844.0, d7 = 69997945.0 / 29380423.0;

  double rtol_;
  State atol_;
  double max_step_;
  double t_ = 0.0, t_old_ = 0.0, h_ = 0.0, h_old_ = 1.0;
  State y_{}, k1_{};
  // The last accepted step, for dense output.
  State y_old_{}, k1_old_{}, k3_{}, k4_{}, k5_{}, k6_{}, k7_{};
  std::size_t steps_ = 0;
  std::size_t evaluations_ = 0;
};

}  // namespace piezo::model
