#include "piezo/model/lugre_hybrid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "piezo/model/hybrid/ringing.hpp"
#include "piezo/model/step_control.hpp"

namespace piezo::model {
namespace {

using namespace hybrid;

/// Bristle states 1 - s kappa z that select the modes: below the first the
/// flip is finished in closed form; above the second the contact sticks.
constexpr double kSaturated = 1e-4;
constexpr double kSticking = 0.3;
/// The smooth part of v must exceed the ringing's velocity amplitude this
/// many times for the ringing not to reverse it before the stick mode,
/// which settles the stator at its first step, takes over.
constexpr double kClearance = 2.0;
/// The same before and through linear steps, which keep the ringing and
/// need only that v does not reverse: within a step the smooth part moves
/// monotonically (the rotor's acceleration is s F_c r/J, the drive's slope
/// fixed) and the ringing decays, so the smooth part at both ends against
/// the amplitude at the start bounds v; the margin covers the split's
/// approximations (the stator's damping ratio is about 1 %).
constexpr double kSlideClearance = 1.25;
/// A series step below this many 1/omega_n is the sign of a stiff bristle.
constexpr double kCrawl = 0.05;
/// Below this tolerance the two approximations (the stator settled at the
/// stick mode's first step, the bristle's flip finished in closed form)
/// leave more error than asked: the integrator resolves both instead.
constexpr double kExactBelow = 1e-6;

/// The state with the stator's free oscillation removed (see ringing.hpp).
LuGreState settle_stator(const MotorParameters& p, LuGreState y, double V, double slope,
                         double F_f) {
  const double X_p = p.d_e * slope;
  y[kX] = p.d_e * V - (F_f + p.C * X_p) / p.K;
  y[kXDot] = X_p;
  return y;
}

LuGreState scaled(LuGreState scale, double tolerance) {
  for (double& a : scale) a *= tolerance;
  return scale;
}

}  // namespace

LuGreHybrid::LuGreHybrid(const MotorParameters& p, double tolerance)
    : p_(p),
      motor_(p),
      series_(p),
      stick_(p, scaled(state_scale<5>(p), tolerance), tolerance),
      slide_(p, 16.0 / std::sqrt(p.K / p.M)),
      inverse_scale_(hybrid::inverse(state_scale<5>(p))),
      tolerance_(tolerance),
      omega_n_(std::sqrt(p.K / p.M)),
      kappa_(p.sigma0 / p.F_c()),
      approximate_(tolerance >= kExactBelow) {}

void LuGreHybrid::reset(double t, const LuGreState& y) {
  t_ = t;
  y_ = y;
  s_ = 0.0;
  mode_ = Mode::series;
  saturated_ = false;
  no_stick_before_ = t;
}

void LuGreHybrid::advance(const LinearPiece& piece, double t_end, StateSamples* samples) {
  mode_ = Mode::series;  // a corner of the drive: the stator rings
  while (t_ < t_end) {
    if (stats_.steps >= progress_at_step_) {
      progress_at_step_ = stats_.steps + kStepsBetweenProgress;
      if (progress_ != nullptr && *progress_) (*progress_)(t_);
    }
    switch (mode_) {
      case Mode::linear:
        if (linear_step(piece, t_end, samples)) continue;
        mode_ = Mode::series;
        break;
      case Mode::stick:
        if (stick_step(piece, t_end, samples)) continue;
        mode_ = Mode::series;
        break;
      case Mode::series:
        series_step(piece, t_end, samples);
        break;
    }
  }
  while (samples != nullptr && samples->next() <= t_end) {
    samples->take(y_, piece.at(samples->next()));
  }
}

void LuGreHybrid::expand(const LinearPiece& piece) {
  const double V0 = piece.at(t_);
  if (s_ == 0.0) {
    series_.expand(y_, V0, piece.slope, 1.0, false, e_);
    s_ = sliding_sign(e_.v);
  }
  series_.expand(y_, V0, piece.slope, s_, saturated_, e_);
  // A contact that slides the other way than s says (v crossed zero by a
  // rounding at the last event): the sign it really has.
  if (s_ * e_.v[0] < 0.0 && s_ * e_.v[1] <= 0.0) {
    s_ = -s_;
    saturated_ = false;
    series_.expand(y_, V0, piece.slope, s_, false, e_);
  }
}

void LuGreHybrid::series_step(const LinearPiece& piece, double t_end, StateSamples* samples) {
  expand(piece);
  // The series' last term is its truncation error, held to the tolerance
  // per step; the cap keeps one extremum of v per half step.
  double h =
      hybrid::allowed_step(e_, inverse_scale_, tolerance_, std::min(4.0 / omega_n_, t_end - t_));
  h = std::max(h, 1e-14 * std::max(1.0, t_));
  const double tau = first_zero(e_.v, s_, h);
  const bool reversal = tau < h;
  const double t1 = tau == t_end - t_ ? t_end : t_ + tau;
  while (samples != nullptr && samples->next() <= t1) {
    const double t = samples->next();
    samples->take(e_.state(t - t_), piece.at(t));
  }
  y_ = e_.state(tau);
  ++stats_.steps;
  ++stats_.series_steps;
  stats_.rhs_evaluations += kOrder;
  t_ = t1;
  if (reversal) {
    // A zero of v: the contact slides the way v' points there.
    ++stats_.mode_switches;
    s_ = slope_at(e_.v, tau) >= 0.0 ? 1.0 : -1.0;
    saturated_ = false;
    return;
  }
  if (t_ < t_end) choose_mode(piece, t_end, h < kCrawl / omega_n_);
}

void LuGreHybrid::choose_mode(const LinearPiece& piece, double t_end, bool crawling) {
  const double rest = 1.0 - s_ * kappa_ * y_[kZ];
  // At a tight tolerance the flip is resolved, unless the series crawls
  // through a bristle already saturated to rounding (rest <= 0, which the
  // exact motion never reaches): far from the prototype's parameters
  // (identification tries them) the flip takes 1e-12 s, and resolving it
  // would take millions of steps.
  if (!saturated_ && rest < kSaturated && (approximate_ || (crawling && rest <= 0.0))) {
    slide_.saturate(y_, s_);
    saturated_ = true;
    ++stats_.saturations;
  }
  const double V = piece.at(t_);
  const double F_f = motor_.friction(y_).force;
  const Ringing ring = split_ringing(p_, y_, V, piece.slope, F_f);
  const bool clear = s_ * ring.smooth_v > kClearance * ring.amplitude;
  ringing_ = ring.amplitude;
  // The linear and stick modes pay off over long pieces of drive; a drive
  // that turns every sample (a replayed log) stays in series mode, which
  // also keeps the stick mode's settling of the stator from adding up.
  const bool long_piece = t_end - t_ >= 2.0 * slide_.step();
  if (saturated_ && s_ * ring.smooth_v > kSlideClearance * ringing_ && long_piece) {
    mode_ = Mode::linear;
  } else if (!saturated_ && rest > kSticking && clear && long_piece && t_ >= no_stick_before_) {
    stick_h_ = std::max(stick_h_, 10.0 / omega_n_);
    mode_ = Mode::stick;
    stiff_ = false;
    settle_ = true;
  } else if (!saturated_ && crawling && t_ >= no_stick_before_) {
    // Parameters far from the prototype's (identification tries them) can
    // make the bristle stiff where it does not stick: the Rosenbrock takes
    // over until v reverses.
    stick_h_ = 10.0 / omega_n_;
    mode_ = Mode::stick;
    stiff_ = true;
    settle_ = false;
  }
}

bool LuGreHybrid::linear_step(const LinearPiece& piece, double t_end, StateSamples* samples) {
  const double h = slide_.step();
  if (t_ + h > t_end) return false;  // the rest of the piece by series
  const double V0 = piece.at(t_);
  LuGreState y1 = y_;
  slide_.advance(y1, V0, piece.slope, s_);
  const double V1 = V0 + piece.slope * h;
  const double F1 = s_ * p_.F_c() + p_.sigma2 * (y1[kXDot] - p_.r * y1[kThetaDot]);
  const Ringing ring = split_ringing(p_, y1, V1, piece.slope, F1);
  if (s_ * ring.smooth_v <= kSlideClearance * ringing_) return false;  // may reverse: resolve
  ringing_ = ring.amplitude;
  interpolate(samples, piece, t_ + h, y1);
  y_ = y1;
  t_ += h;
  ++stats_.steps;
  ++stats_.linear_steps;
  return true;
}

bool LuGreHybrid::stick_step(const LinearPiece& piece, double t_end, StateSamples* samples) {
  const double V0 = piece.at(t_);
  // The first step from a ringing stator starts from it settled: the
  // Rosenbrock would resolve the ringing in microsecond steps, and its part
  // in the rotor's motion is below the tolerance once the smooth v clears
  // it (three times the stick steps at 10 Hz without this). Kept only if
  // the step holds, so that a series that takes over again starts from the
  // state as it was.
  const LuGreState y0 = settle_ && approximate_
                            ? settle_stator(p_, y_, V0, piece.slope, motor_.friction(y_).force)
                            : y_;
  double h = std::min(stick_h_, t_end - t_);
  LuGreState y1{};
  for (;;) {
    double error = stick_.step(y0, V0, piece.slope, s_, h, y1);
    if (!std::isfinite(error)) error = 1e10;  // overflowed: a far smaller step
    const double factor = 0.9 / std::sqrt(std::sqrt(std::max(error, 1e-10)));  // error^-1/4
    stats_.rhs_evaluations += 6;
    if (error <= 1.0) {
      stick_h_ = h * std::clamp(factor, 0.2, 5.0);
      break;
    }
    h *= std::clamp(factor, 0.2, 0.9);
    ++stats_.rejected_steps;
    if (h < kCrawl / omega_n_) {
      // No better than the series: leave the stretch to it.
      no_stick_before_ = t_ + 10.0 / omega_n_;
      return false;
    }
  }
  if (s_ * (y1[kXDot] - p_.r * y1[kThetaDot]) <= 0.0) {
    no_stick_before_ = t_ + h;  // v reversed in this step: the series locates it
    return false;
  }
  y_ = y0;
  settle_ = false;
  const double t1 = h == t_end - t_ ? t_end : t_ + h;
  interpolate(samples, piece, t1, y1);
  y_ = y1;
  t_ = t1;
  ++stats_.steps;
  ++stats_.stick_steps;
  if (!stiff_ && 1.0 - s_ * kappa_ * y_[kZ] < kSticking) mode_ = Mode::series;  // it lets go
  return true;
}

void LuGreHybrid::interpolate(StateSamples* samples, const LinearPiece& piece, double t1,
                              const LuGreState& y1) const {
  if (samples == nullptr || samples->next() > t1) return;
  LuGreState f0{}, f1{};
  stick_.derivative(y_, piece.at(t_), s_, f0);
  stick_.derivative(y1, piece.at(t1), s_, f1);
  samples->take_from(StateCubic(t_, y_, f0, t1, y1, f1), piece, t1);
}

namespace {

constexpr std::size_t kFrictionColumn = 7;
static_assert(kColumnNames[kFrictionColumn] == "F_f");

/// simulate()'s samples: every requested time, recorded into a Trajectory.
/// A sample's values go into a block of rows first, and a full block into
/// the columns kept, a copy per column: no capacity check or skipped column
/// per value (the samples cost as much as the integration otherwise).
class Recorder final : public StateSamples {
 public:
  Recorder(std::span<const double> times, const MotorParameters& p, Trajectory& out)
      : times_(times), motor_(p), out_(out), columns_{&out.t,     &out.V,     &out.x,
                                                      &out.x_dot, &out.theta, &out.theta_dot,
                                                      &out.z,     &out.F_f} {
    out_.reserve(times.size());
    move_on();
  }

  void take(const LuGreState& y, double V) override {
    // The friction force only for a caller that records it.
    const double F_f = out_.columns[kFrictionColumn] ? motor_.friction(y).force : 0.0;
    block_[1][rows_] = V;
    for (std::size_t i = 0; i < 5; ++i) block_[2 + i][rows_] = y[i];
    block_[kFrictionColumn][rows_] = F_f;
    ++next_;
    move_on();
    if (++rows_ == kRows) flush();
  }
  /// A step's samples as whole columns of the block: loops over the
  /// samples per state, which the compiler vectorises.
  void take_from(const StateCubic& cubic, const LinearPiece& piece, double t1) override {
    while (next() <= t1) {
      std::size_t n = 0;
      while (rows_ + n < kRows && next_ + n < times_.size() && times_[next_ + n] <= t1) ++n;
      const double* t = times_.data() + next_;
      std::array<double, kRows> u;
      for (std::size_t j = 0; j < n; ++j) u[j] = cubic.u(t[j]);
      for (std::size_t i = 0; i < 5; ++i) {
        double* column = block_[2 + i].data() + rows_;
        for (std::size_t j = 0; j < n; ++j) column[j] = cubic.at(i, u[j]);
      }
      double* V = block_[1].data() + rows_;
      for (std::size_t j = 0; j < n; ++j) V[j] = piece.at(t[j]);
      if (out_.columns[kFrictionColumn]) {
        const double *x_dot = block_[3].data() + rows_, *theta_dot = block_[5].data() + rows_;
        const double* z = block_[6].data() + rows_;
        double* F_f = block_[kFrictionColumn].data() + rows_;
        for (std::size_t j = 0; j < n; ++j)
          F_f[j] = motor_.friction(x_dot[j], theta_dot[j], z[j]).force;
      }
      next_ += n;
      rows_ += n;
      move_on();
      if (rows_ == kRows) flush();
    }
  }
  [[nodiscard]] bool done() const { return next_ >= times_.size(); }

  void move_on() {
    set_next(next_ < times_.size() ? times_[next_] : std::numeric_limits<double>::infinity());
  }

  /// The rows not yet in the columns, into them: once the run is over.
  void flush() {
    const std::size_t first = next_ - rows_;
    columns_[0]->insert(columns_[0]->end(), times_.begin() + static_cast<std::ptrdiff_t>(first),
                        times_.begin() + static_cast<std::ptrdiff_t>(next_));
    for (std::size_t c = 1; c < columns_.size(); ++c) {
      if (out_.columns[c])
        columns_[c]->insert(columns_[c]->end(), block_[c].begin(),
                            block_[c].begin() + static_cast<std::ptrdiff_t>(rows_));
    }
    rows_ = 0;
  }

 private:
  static constexpr std::size_t kRows = 256;
  std::span<const double> times_;
  LuGreMotor motor_;
  Trajectory& out_;
  std::array<std::vector<double>*, kColumnNames.size()> columns_;
  std::array<std::array<double, kRows>, kColumnNames.size()> block_{};  // [column][row]; t unused
  std::size_t next_ = 0, rows_ = 0;
};

}  // namespace

Trajectory simulate_lugre_hybrid(const MotorParameters& p, const Excitation& drive,
                                 std::span<const double> times, const IntegratorSettings& settings,
                                 Trajectory storage) {
  Trajectory out = std::move(storage);
  out.restart(settings.columns);
  if (!times.empty() && (times.front() < 0.0 || !std::is_sorted(times.begin(), times.end()))) {
    throw std::invalid_argument("sample times must be non-negative and non-decreasing");
  }
  Recorder recorder(times, p, out);
  LuGreHybrid motor(p, settings.tolerance);
  motor.report_progress(settings.progress);
  motor.reset(0.0, LuGreState{});
  while (recorder.next() <= 0.0) recorder.take(motor.state(), drive.voltage(recorder.next()));
  while (!recorder.done()) {
    const double t = motor.time();
    if (settings.progress) settings.progress(t);
    const PieceSpan span = drive.span(t);
    motor.advance(span.piece, std::min(span.end, times.back()), &recorder);
  }
  recorder.flush();
  out.stats = motor.stats();
  out.stats.integrator = Integrator::hybrid;
  return out;
}

}  // namespace piezo::model
