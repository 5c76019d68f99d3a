// SUNDIALS against the project's own integrators on the LuGre motor (4.8 s
// at the paper baseline, 10 and 20 Hz): CVODE's BDF with the analytic
// Jacobian, and ARKODE's ImEx Runge-Kutta with the linear stator implicit
// and the friction explicit. Each is run at a ladder of tolerances, and
// each run shows its time, steps, right-hand-side evaluations and error
// against DOPRI5 at 1e-11, beside DOPRI5 at its default and RK4 at 1 us.
// Usage: bench_sundials [repeats]   (medians)

#include <arkode/arkode_arkstep.h>
#include <cvode/cvode.h>
#include <fmt/format.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "../support/fixed_step_reference.hpp"
#include "../support/median_time.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/step_control.hpp"

using namespace piezo;

namespace {

struct Problem {
  model::MotorParameters p;
  const model::Excitation* drive;
  model::LuGreMotor motor;
};

void check(int flag, const char* what) {
  if (flag < 0) throw std::runtime_error(fmt::format("{} failed: {}", what, flag));
}

model::LuGreState to_state(N_Vector y) {
  const double* d = N_VGetArrayPointer(y);
  return {d[0], d[1], d[2], d[3], d[4]};
}

int lugre_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* data) {
  auto& pr = *static_cast<Problem*>(data);
  model::LuGreState dy;
  pr.motor.derivative(pr.drive->voltage(t), to_state(y), dy);
  std::copy(dy.begin(), dy.end(), N_VGetArrayPointer(ydot));
  return 0;
}

// d(rhs)/dy of the LuGre equations (docs/model.md section 2), with sgn(0) = 0.
int lugre_jacobian(sunrealtype, N_Vector y, N_Vector, SUNMatrix J, void* data, N_Vector, N_Vector,
                   N_Vector) {
  const auto& p = static_cast<Problem*>(data)->p;
  const auto s = to_state(y);
  const double v = s[1] - p.r * s[3];
  const double sgn = (v > 0) - (v < 0);
  const double a = 1.0 - p.sigma0 * sgn * s[4] / p.F_c();  // dz'/dv
  const double b = -p.sigma0 * std::abs(v) / p.F_c();      // dz'/dz
  const double dF_dv = p.sigma1 * a + p.sigma2;
  const double dF_dz = p.sigma0 + p.sigma1 * b;
  SUNMatZero(J);
  auto at = [&](int i, int j) -> double& { return SM_ELEMENT_D(J, i, j); };
  at(0, 1) = 1.0;
  at(1, 0) = -p.K / p.M;
  at(1, 1) = (-p.C - dF_dv) / p.M;
  at(1, 3) = p.r * dF_dv / p.M;
  at(1, 4) = -dF_dz / p.M;
  at(2, 3) = 1.0;
  at(3, 1) = p.r * dF_dv / p.J;
  at(3, 3) = -p.r * p.r * dF_dv / p.J;
  at(3, 4) = p.r * dF_dz / p.J;
  at(4, 1) = a;
  at(4, 3) = -p.r * a;
  at(4, 4) = b;
  return 0;
}

// ImEx split: the stator's own spring and damper implicit (linear, constant
// Jacobian); the drive and everything friction explicit.
int stator_implicit(sunrealtype, N_Vector y, N_Vector ydot, void* data) {
  const auto& p = static_cast<Problem*>(data)->p;
  const double* s = N_VGetArrayPointer(y);
  double* d = N_VGetArrayPointer(ydot);
  d[0] = s[1];
  d[1] = (-p.C * s[1] - p.K * s[0]) / p.M;
  d[2] = d[3] = d[4] = 0.0;
  return 0;
}

int stator_implicit_jacobian(sunrealtype, N_Vector, N_Vector, SUNMatrix J, void* data, N_Vector,
                             N_Vector, N_Vector) {
  const auto& p = static_cast<Problem*>(data)->p;
  SUNMatZero(J);
  SM_ELEMENT_D(J, 0, 1) = 1.0;
  SM_ELEMENT_D(J, 1, 0) = -p.K / p.M;
  SM_ELEMENT_D(J, 1, 1) = -p.C / p.M;
  return 0;
}

int friction_explicit(sunrealtype t, N_Vector y, N_Vector ydot, void* data) {
  auto& pr = *static_cast<Problem*>(data);
  const auto s = to_state(y);
  const auto fr = pr.motor.friction(s);
  double* d = N_VGetArrayPointer(ydot);
  d[0] = 0.0;
  d[1] = (pr.p.K * pr.p.d_e * pr.drive->voltage(t) - fr.force) / pr.p.M;
  d[2] = s[3];
  d[3] = pr.p.r * fr.force / pr.p.J;
  d[4] = fr.z_rate;
  return 0;
}

struct Outcome {
  double angle = 0.0;
  long steps = 0, rhs = 0;
};

/// Integrates segment by segment (stopping exactly on every drive corner)
/// with tolerance `tol` on the same scaled state as DOPRI5.
Outcome run_sundials(bool cvode, Problem& pr, double t_end, double tol) {
  SUNContext ctx;
  check(SUNContext_Create(nullptr, &ctx), "SUNContext_Create");
  N_Vector y = N_VNew_Serial(5, ctx);
  N_Vector atol = N_VNew_Serial(5, ctx);
  N_VConst(0.0, y);
  const auto scale = model::state_scale<5>(pr.p);
  for (int i = 0; i < 5; ++i) NV_Ith_S(atol, i) = scale[static_cast<std::size_t>(i)] * tol;
  SUNMatrix A = SUNDenseMatrix(5, 5, ctx);
  SUNLinearSolver LS = SUNLinSol_Dense(y, A, ctx);
  void* mem = nullptr;
  if (cvode) {
    mem = CVodeCreate(CV_BDF, ctx);
    check(CVodeInit(mem, lugre_rhs, 0.0, y), "CVodeInit");
    check(CVodeSVtolerances(mem, tol, atol), "CVodeSVtolerances");
    check(CVodeSetUserData(mem, &pr), "CVodeSetUserData");
    check(CVodeSetLinearSolver(mem, LS, A), "CVodeSetLinearSolver");
    check(CVodeSetJacFn(mem, lugre_jacobian), "CVodeSetJacFn");
    check(CVodeSetMaxNumSteps(mem, 100'000'000), "CVodeSetMaxNumSteps");
  } else {
    mem = ARKStepCreate(friction_explicit, stator_implicit, 0.0, y, ctx);
    check(ARKStepSVtolerances(mem, tol, atol), "ARKStepSVtolerances");
    check(ARKStepSetUserData(mem, &pr), "ARKStepSetUserData");
    check(ARKStepSetLinearSolver(mem, LS, A), "ARKStepSetLinearSolver");
    check(ARKStepSetJacFn(mem, stator_implicit_jacobian), "ARKStepSetJacFn");
    check(ARKStepSetLinear(mem, 0), "ARKStepSetLinear");
    check(ARKStepSetMaxNumSteps(mem, 100'000'000), "ARKStepSetMaxNumSteps");
  }
  Outcome out;
  double t = 0.0;
  while (t < t_end) {
    const double segment_end = std::min(pr.drive->next_breakpoint(t), t_end);
    if (cvode) {
      check(CVodeSetStopTime(mem, segment_end), "CVodeSetStopTime");
      check(CVode(mem, segment_end, y, &t, CV_NORMAL), "CVode");
    } else {
      check(ARKStepSetStopTime(mem, segment_end), "ARKStepSetStopTime");
      check(ARKStepEvolve(mem, segment_end, y, &t, ARK_NORMAL), "ARKStepEvolve");
    }
    t = segment_end;
  }
  if (cvode) {
    CVodeGetNumSteps(mem, &out.steps);
    CVodeGetNumRhsEvals(mem, &out.rhs);
  } else {
    long fe = 0, fi = 0;
    ARKStepGetNumSteps(mem, &out.steps);
    ARKStepGetNumRhsEvals(mem, &fe, &fi);
    out.rhs = fe + fi;
  }
  out.angle = NV_Ith_S(y, 2);
  if (cvode) {
    CVodeFree(&mem);
  } else {
    ARKStepFree(&mem);
  }
  SUNLinSolFree(LS);
  SUNMatDestroy(A);
  N_VDestroy(atol);
  N_VDestroy(y);
  SUNContext_Free(&ctx);
  return out;
}

}  // namespace

using testing::median_seconds;

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 3;
  constexpr double kRuntime = 4.8;
  fmt::print("{:<5} {:<22} | {:>9} {:>9} {:>10} {:>9} | {:>8}\n", "f/Hz", "integrator", "time/ms",
             "steps", "rhs evals", "rel.err", "vs rk4");
  for (double f : {10.0, 20.0}) {
    model::Parameters params;
    params.drive.f = f;
    const model::Sawtooth drive(params.drive.V0, f, params.drive.D());
    Problem pr{params.motor, &drive, model::LuGreMotor(params.motor)};
    const double reference =
        model::final_angle(params.motor, drive, model::FrictionModel::lugre, kRuntime,
                           {.tolerance = 1e-11, .integrator = model::Integrator::dopri5});
    const double t_rk4 = median_seconds(
        repeats, [&] { (void)testing::lugre_rk4_angle(params.motor, drive, kRuntime, 1e-6); });
    auto row = [&](const std::string& name, double seconds, long steps, long rhs, double angle) {
      fmt::print("{:<5g} {:<22} | {:>9.2f} {:>9} {:>10} {:>9.1e} | {:>7.1f}x\n", f, name,
                 1e3 * seconds, steps, rhs, std::abs(angle - reference) / std::abs(reference),
                 t_rk4 / seconds);
    };
    row("rk4 1us", t_rk4, static_cast<long>(kRuntime / 1e-6),
        4 * static_cast<long>(kRuntime / 1e-6),
        testing::lugre_rk4_angle(params.motor, drive, kRuntime, 1e-6));
    const double times[] = {kRuntime};
    model::Trajectory dopri;
    const double t_dopri = median_seconds(repeats, [&] {
      dopri = model::simulate(params.motor, drive, model::FrictionModel::lugre, times, {});
    });
    row("dopri5 1e-6 (default)", t_dopri, static_cast<long>(dopri.stats.steps),
        static_cast<long>(dopri.stats.rhs_evaluations), dopri.theta.back());
    for (bool cvode : {true, false}) {
      for (double tol : {1e-4, 1e-5, 1e-6, 1e-7}) {
        Outcome o;
        const double seconds =
            median_seconds(repeats, [&] { o = run_sundials(cvode, pr, kRuntime, tol); });
        row(fmt::format("{} {:.0e}", cvode ? "cvode bdf" : "arkode imex", tol), seconds, o.steps,
            o.rhs, o.angle);
      }
    }
  }
  fmt::print(
      "rel.err = |theta(4.8 s) - ref| / |ref|, ref = dopri5 at 1e-11; tolerances on the same "
      "scaled state as dopri5; every integrator stops on each drive corner\n");
  return 0;
}
