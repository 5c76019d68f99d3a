#include "piezo/model/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "piezo/model/coulomb_closed_form.hpp"
#include "piezo/model/dopri5.hpp"
#include "piezo/model/lugre_hybrid.hpp"
#include "piezo/model/step_control.hpp"

namespace piezo::model {

std::vector<double> uniform_times(double duration, double interval, std::vector<double> storage) {
  std::vector<double> times = std::move(storage);
  times.clear();
  const auto n = static_cast<std::size_t>(std::floor(duration / interval + 1e-9));
  times.reserve(n + 2);
  for (std::size_t i = 0; i <= n; ++i) times.push_back(static_cast<double>(i) * interval);
  if (duration - times.back() > 1e-12 * std::max(1.0, duration)) times.push_back(duration);
  return times;
}

void Trajectory::reserve(std::size_t n) {
  const std::array all{&t, &V, &x, &x_dot, &theta, &theta_dot, &z, &F_f};
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i == 0 || columns[i]) all[i]->reserve(n);
  }
}

void Trajectory::restart(ColumnSet kept) {
  for (auto* column : {&t, &V, &x, &x_dot, &theta, &theta_dot, &z, &F_f, &switch_times}) {
    column->clear();
  }
  stats = {};
  columns = kept;
}

void Trajectory::append(double t_s, double V_volts, std::span<const double> state,
                        double F_f_value) {
  t.push_back(t_s);
  const std::array all{&V, &x, &x_dot, &theta, &theta_dot, &z, &F_f};
  const double values[] = {V_volts,       state[kX],        state[kXDot],
                           state[kTheta], state[kThetaDot], state.size() > kZ ? state[kZ] : 0.0,
                           F_f_value};
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (columns[i + 1]) all[i]->push_back(values[i]);
  }
}

namespace {

/// As LuGreHybrid's: progress within a piece of drive this often.
constexpr std::size_t kStepsBetweenProgress = LuGreHybrid::kStepsBetweenProgress;

template <std::size_t N>
struct Event {
  double t;
  std::array<double, N> y;  ///< state to restart from
};

/// Integrates dy/dt = rhs(y, V(t)) with Dormand-Prince 5(4), restarting
/// exactly at each breakpoint of the drive, emitting the state at each sample
/// time from the dense output, and letting `on_step` cut a step short at an
/// event (a change of the right-hand side, e.g. stick/slip) it located inside it.
template <std::size_t N, class Rhs, class Emit, class OnStep>
IntegrationStats integrate(const MotorParameters& p, Rhs&& rhs, const Excitation& drive,
                           std::span<const double> times, const IntegratorSettings& settings,
                           Emit&& emit, OnStep&& on_step) {
  const double tolerance = settings.tolerance;
  const auto& progress = settings.progress;
  using State = std::array<double, N>;
  IntegrationStats stats;
  if (times.empty()) return stats;
  if (times.front() < 0.0 || !std::is_sorted(times.begin(), times.end())) {
    throw std::invalid_argument("sample times must be non-negative and non-decreasing");
  }
  State atol = state_scale<N>(p);
  for (double& a : atol) a *= tolerance;
  Dopri5<N> stepper(tolerance, atol, max_stable_step(p));
  LinearPiece voltage{0.0, 0.0, 0.0};
  auto system = [&](const State& y, State& dydt, double t) { rhs(y, dydt, voltage.at(t)); };

  std::size_t next = 0;
  State y{};
  while (next < times.size() && times[next] <= 0.0) emit(times[next++], y);

  const double t_end = times.back();
  double t = 0.0;
  double h = 1e-7;
  std::size_t steps_since_progress = 0;
  while (next < times.size()) {
    const double seg_end = std::min(drive.next_breakpoint(t), t_end);
    const double at_end = 1e-13 * std::max(1.0, seg_end);
    voltage = drive.piece(t);
    if (progress) progress(t);
    stepper.initialize(system, t, y, std::min(h, seg_end - t));
    while (seg_end - stepper.time() > at_end) {
      // Within a piece too: stiff parameters take millions of steps in one.
      if (progress && ++steps_since_progress == kStepsBetweenProgress) {
        steps_since_progress = 0;
        progress(stepper.time());
      }
      stepper.step(system, seg_end - stepper.time());
      const std::optional<Event<N>> event = on_step(stepper);
      const double emitted_until = event ? event->t : stepper.time();
      while (next < times.size() && times[next] <= emitted_until) {
        emit(times[next], stepper.dense(times[next]));
        ++next;
      }
      if (event) {
        ++stats.mode_switches;
        stepper.initialize(system, event->t, event->y, stepper.proposed_step());
      }
    }
    y = stepper.state();
    t = seg_end;
    h = stepper.proposed_step();
    // Samples at t_end that rounding kept out of the last step.
    if (seg_end >= t_end) {
      while (next < times.size()) emit(times[next++], y);
    }
  }
  stats.steps = stepper.steps();
  stats.rhs_evaluations = stepper.evaluations();
  return stats;
}

/// Finds the time in the last step where `crossed(t, y)` first becomes true,
/// by bisection on the stepper's dense output.
template <class Stepper, class Crossed>
auto locate(const Stepper& stepper, Crossed&& crossed) {
  double lo = stepper.previous_time(), hi = stepper.time();
  for (int i = 0; i < 60 && hi - lo > 1e-14 * std::max(1.0, hi); ++i) {
    const double mid = 0.5 * (lo + hi);
    (crossed(mid, stepper.dense(mid)) ? hi : lo) = mid;
  }
  return std::make_pair(hi, stepper.dense(hi));
}

Trajectory simulate_lugre(const MotorParameters& p, const Excitation& drive,
                          std::span<const double> times, const IntegratorSettings& settings,
                          Trajectory storage) {
  Trajectory out = std::move(storage);
  out.restart(settings.columns);
  out.reserve(times.size());
  const LuGreMotor motor(p);
  auto rhs = [&](const LuGreState& y, LuGreState& dydt, double V) { motor.derivative(V, y, dydt); };
  auto emit = [&](double t, const LuGreState& y) {
    out.append(t, drive.voltage(t), y, motor.friction(y).force);
  };
  // With reversal events, a step in which v changed sign ends at the zero
  // (located on the dense output), so that no step straddles the kink of |v|.
  auto reversals = [&](const auto& stepper) -> std::optional<Event<5>> {
    if (!settings.reversal_events) return std::nullopt;
    const double before = sliding_velocity(p, stepper.dense(stepper.previous_time()));
    const double after = sliding_velocity(p, stepper.state());
    if (before == 0.0 || (before > 0.0) == (after > 0.0)) return std::nullopt;
    const auto [t_event, y] = locate(stepper, [&](double, const LuGreState& ys) {
      return (sliding_velocity(p, ys) > 0.0) != (before > 0.0);
    });
    return Event<5>{t_event, y};
  };
  out.stats = integrate<5>(p, rhs, drive, times, settings, emit, reversals);
  return out;
}

Trajectory simulate_coulomb(const MotorParameters& p, const Excitation& drive,
                            std::span<const double> times, const IntegratorSettings& settings,
                            Trajectory storage) {
  Trajectory out = std::move(storage);
  out.restart(settings.columns);
  out.reserve(times.size());
  ContactMode mode = ContactMode::stick;
  auto rhs = [&](const CoulombState& y, CoulombState& dydt, double V) {
    coulomb_derivative(p, V, mode, y, dydt);
  };
  auto emit = [&](double t, const CoulombState& y) {
    out.append(t, drive.voltage(t), y, coulomb_friction(p, drive.voltage(t), mode, y));
  };
  auto stick_force = [&](double t, const CoulombState& y) {
    return coulomb_stick_force(p, drive.voltage(t), y);
  };
  // Karnopp switching: slip ends when v returns to zero; the contact then
  // sticks if the force needed to hold it is within F_c, and otherwise slips
  // the other way. Stick ends when the holding force would exceed F_c.
  auto on_step = [&](const auto& stepper) -> std::optional<Event<4>> {
    const double t1 = stepper.time();
    const CoulombState& y1 = stepper.state();
    if (mode == ContactMode::stick) {
      if (std::abs(stick_force(t1, y1)) <= p.F_c()) return std::nullopt;
      // The holding force depends on t through V(t), so the predicate takes both.
      const auto [t_event, y] = locate(stepper, [&](double t, const CoulombState& ys) {
        return std::abs(stick_force(t, ys)) > p.F_c();
      });
      mode = stick_force(t_event, y) > 0 ? ContactMode::slip_forward : ContactMode::slip_backward;
      out.switch_times.push_back(t_event);
      return Event<4>{t_event, y};
    }
    const double direction = mode == ContactMode::slip_forward ? 1.0 : -1.0;
    if (direction * sliding_velocity(p, y1) > 0.0) return std::nullopt;
    auto [t_event, y] = locate(stepper, [&](double, const CoulombState& ys) {
      return direction * sliding_velocity(p, ys) <= 0.0;
    });
    mode = coulomb_mode_after_slip(p, drive.voltage(t_event), y);
    if (mode == ContactMode::stick) y[kThetaDot] = y[kXDot] / p.r;  // lock exactly: v = 0
    out.switch_times.push_back(t_event);
    return Event<4>{t_event, y};
  };
  out.stats = integrate<4>(p, rhs, drive, times, settings, emit, on_step);
  return out;
}

}  // namespace

Trajectory simulate(const MotorParameters& p, const Excitation& drive, FrictionModel model,
                    std::span<const double> sample_times, const IntegratorSettings& settings,
                    Trajectory storage) {
  switch (settings.integrator) {
    case Integrator::model_default:
      if (model == FrictionModel::lugre)
        return simulate_lugre_hybrid(p, drive, sample_times, settings, std::move(storage));
      if (coulomb_closed_form_applies(p)) {
        return simulate_coulomb_closed_form(p, drive, sample_times, settings, std::move(storage));
      }
      break;
    case Integrator::dopri5:
      break;
    case Integrator::closed_form:
      if (model == FrictionModel::lugre) {
        throw std::invalid_argument(
            "integrator closed_form: Coulomb model only (the LuGre bristle has no closed form); "
            "use dopri5");
      }
      return simulate_coulomb_closed_form(p, drive, sample_times, settings, std::move(storage));
    case Integrator::hybrid:
      if (model == FrictionModel::coulomb) {
        throw std::invalid_argument(
            "integrator hybrid: LuGre model only (Coulomb runs in closed form); use closed_form");
      }
      return simulate_lugre_hybrid(p, drive, sample_times, settings, std::move(storage));
  }
  return model == FrictionModel::lugre
             ? simulate_lugre(p, drive, sample_times, settings, std::move(storage))
             : simulate_coulomb(p, drive, sample_times, settings, std::move(storage));
}

double final_angle(const MotorParameters& p, const Excitation& drive, FrictionModel model,
                   double t_end, const IntegratorSettings& settings) {
  const double times[] = {t_end};
  return simulate(p, drive, model, times, settings).theta.back();
}

}  // namespace piezo::model
