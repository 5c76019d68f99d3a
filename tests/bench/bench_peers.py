#!/usr/bin/python3
"""The LuGre model at the Table 1 baseline for 4.8 s, solved the way a
researcher would otherwise solve it -- SciPy's solve_ivp (LSODA, Radau,
DOP853), GNU Octave's ode45 and ode15s (MATLAB's solvers' twins) and a
fixed-step RK4 at 1 us compiled by numba, each on the equations of
docs/model.md written in its own language -- beside
piezo_rig.model.simulate and `piezo simulate`, one run on one machine.

For each peer the tolerance is tightened (1e-5, 1e-7, 1e-9, 1e-11 relative,
absolute scaled to each state) until the angle is within 1e-4 (relative to
the final angle, at every 1 ms sample) of the converged solution (the
project's hybrid integrator at 1e-10, itself checked against DOPRI5 at
1e-10); the table shows the first tolerance that meets it: wall time,
steps, right-hand-side evaluations, error. A peer that needs more than
--budget seconds for one solve is reported as such.

The numba row is one fixed step, not a tolerance: its wall time is the
solve after a first call has compiled it (the compile time is printed
beside).

usage: bench_peers.py PIEZO_BINARY [--budget S] [--skip-octave]
(PYTHONPATH=<build>/python; needs python3-scipy, and octave and
python3-numba for their rows)"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from piezo_rig import model

DURATION, GOAL = 4.8, 1e-4
TOLERANCES = (1e-5, 1e-7, 1e-9, 1e-11)
p = model.Parameters()
T, D = 1.0 / p.f, p.C_dr * p.e_dr
Fc = p.mu * p.F_N
# Typical magnitudes of x, x', theta, theta', z: the absolute tolerances.
SCALE = np.array([p.d_e * p.V0, p.d_e * p.V0 * 2 * math.pi * 5700, 0.05, 0.05, Fc / p.sigma0])
SAMPLES = np.linspace(0.0, DURATION, 4801)


def rhs(t, y):
    x, xd, th, thd, z = y
    tau = t % T
    V = p.V0 * tau / (D * T) if tau < D * T else p.V0 * (T - tau) / ((1 - D) * T)
    v = xd - p.r * thd
    zd = v - p.sigma0 * abs(v) * z / Fc
    F = p.sigma0 * z + p.sigma1 * zd + p.sigma2 * v
    return [xd, (p.K * p.d_e * V - p.C * xd - p.K * x - F) / p.M, thd, p.r * F / p.J, zd]


OCTAVE = r"""
p = struct(%(params)s);
T = 1/p.f; D = p.C_dr*p.e_dr; Fc = p.mu*p.F_N;
function dy = lugre(t, y, p, T, D, Fc)
  tau = mod(t, T);
  if tau < D*T, V = p.V0*tau/(D*T); else V = p.V0*(T - tau)/((1 - D)*T); end
  v = y(2) - p.r*y(4);
  zd = v - p.sigma0*abs(v)*y(5)/Fc;
  F = p.sigma0*y(5) + p.sigma1*zd + p.sigma2*v;
  dy = [y(2); (p.K*p.d_e*V - p.C*y(2) - p.K*y(1) - F)/p.M; y(4); p.r*F/p.J; zd];
end
opts = odeset('RelTol', %(rtol)g, 'AbsTol', %(atol)s, 'InitialStep', 1e-7);
tic; [t, y] = %(solver)s(@(t, y) lugre(t, y, p, T, D, Fc), linspace(0, %(duration)g, 4801), zeros(5, 1), opts); wall = toc;
printf('%%.17g\n', wall); printf('%%d\n', numel(t)); printf('%%.17g\n', y(:, 3));
"""


def error(theta, reference):
    return float(np.max(np.abs(theta - reference)) / abs(reference[-1]))


def scipy_solve(method, tol):
    from scipy.integrate import solve_ivp
    start = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, DURATION), np.zeros(5), method=method, t_eval=SAMPLES, rtol=tol,
                    atol=tol * SCALE)
    wall = time.perf_counter() - start
    if not sol.success:
        raise RuntimeError(sol.message)
    # solve_ivp does not count its steps; its right-hand-side evaluations say the cost.
    return wall, sol.y[2], {"rhs_evaluations": sol.nfev, "steps": None}


def octave_solve(solver, tol, budget):
    params = ", ".join(f"'{k}', {v!r}" for k, v in p.to_dict().items() if k != "direction")
    script = OCTAVE % {"params": params, "rtol": tol,
                       "atol": "[" + "; ".join(f"{tol * s:g}" for s in SCALE) + "]",
                       "solver": solver, "duration": DURATION}
    with tempfile.NamedTemporaryFile("w", suffix=".m", delete=False) as f:
        f.write("1;\n" + script)
    try:
        out = subprocess.run(["octave-cli", "--no-gui", "--quiet", f.name], capture_output=True,
                             text=True, timeout=budget)
    finally:
        os.unlink(f.name)
    if out.returncode != 0:
        raise RuntimeError(out.stderr.strip()[-300:])
    values = out.stdout.split()
    return float(values[0]), np.array([float(v) for v in values[2:]]), {"steps": None,
                                                                         "rhs_evaluations": None}


def numba_rk4(step_s):
    """Classic RK4 at a fixed step, the model's right-hand side and the loop
    compiled by numba; theta every 1 ms. Returns (wall, compile, theta)."""
    import numba
    V0, f, C_dr, e_dr = p.V0, p.f, p.C_dr, p.e_dr
    M, C, K, d_e, J, r = p.M, p.C, p.K, p.d_e, p.J, p.r
    s0, s1, s2 = p.sigma0, p.sigma1, p.sigma2
    period, rise = 1.0 / f, C_dr * e_dr

    @numba.njit(cache=False, fastmath=False)
    def derivative(t, y, out):
        tau = t % period
        if tau < rise * period:
            V = V0 * tau / (rise * period)
        else:
            V = V0 * (period - tau) / ((1 - rise) * period)
        v = y[1] - r * y[3]
        zd = v - s0 * abs(v) * y[4] / Fc
        F = s0 * y[4] + s1 * zd + s2 * v
        out[0] = y[1]
        out[1] = (K * d_e * V - C * y[1] - K * y[0] - F) / M
        out[2] = y[3]
        out[3] = r * F / J
        out[4] = zd

    @numba.njit(cache=False)
    def solve(h, steps, every):
        y = np.zeros(5)
        k1, k2, k3, k4, tmp = np.zeros(5), np.zeros(5), np.zeros(5), np.zeros(5), np.zeros(5)
        theta = np.zeros(steps // every + 1)
        for n in range(steps):
            t = n * h
            derivative(t, y, k1)
            for i in range(5):
                tmp[i] = y[i] + 0.5 * h * k1[i]
            derivative(t + 0.5 * h, tmp, k2)
            for i in range(5):
                tmp[i] = y[i] + 0.5 * h * k2[i]
            derivative(t + 0.5 * h, tmp, k3)
            for i in range(5):
                tmp[i] = y[i] + h * k3[i]
            derivative(t + h, tmp, k4)
            for i in range(5):
                y[i] += h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
            if (n + 1) % every == 0:
                theta[(n + 1) // every] = y[2]
        return theta

    every = round(1e-3 / step_s)
    steps = round(DURATION / step_s)
    start = time.perf_counter()
    solve(step_s, every, every)  # compiles both functions
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    theta = solve(step_s, steps, every)
    return time.perf_counter() - start, compile_s, theta


def own_simulate(tol):
    start = time.perf_counter()
    sim = model.simulate(p, DURATION, dt=1e-3, tolerance=tol)
    return time.perf_counter() - start, sim.theta, {"steps": sim.integrator["steps"],
                                                    "rhs_evaluations": None}


def cli_simulate(binary, tol):
    start = time.perf_counter()
    out = subprocess.run([binary, "simulate", "--json", "--duration", str(DURATION), "--dt", "1e-3",
                          "--tolerance", str(tol)], capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    j = json.loads(out.stdout)
    return wall, None, {"steps": j["integrator"]["steps"], "theta_end": j["theta_end_rad"]}


def tighten(name, solve, reference, budget):
    """The first tolerance meeting the goal: (tol, wall, steps, evaluations, error) or why not."""
    for tol in TOLERANCES:
        started = time.perf_counter()
        try:
            wall, theta, extra = solve(tol)
        except subprocess.TimeoutExpired:
            return {"name": name, "tol": tol, "note": f"over the {budget:g} s budget"}
        except Exception as e:  # a solver that fails is reported, the others go on
            # One table cell: the message's lines run together, its start kept.
            return {"name": name, "tol": tol, "note": "failed: " + " ".join(str(e).split())[:160]}
        e = error(theta, reference)
        print(f"  {name} at {tol:g}: {wall:.3f} s, error {e:.2e}", file=sys.stderr, flush=True)
        if e <= GOAL:
            return {"name": name, "tol": tol, "wall": wall, "error": e, **extra}
        if time.perf_counter() - started > budget:
            return {"name": name, "tol": tol, "note": f"error {e:.1e}; the next tolerance is over "
                                                      f"the {budget:g} s budget"}
    return {"name": name, "tol": TOLERANCES[-1], "note": f"error {e:.1e} at the tightest"}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("piezo")
    parser.add_argument("--budget", type=float, default=900.0)
    parser.add_argument("--skip-octave", action="store_true")
    args = parser.parse_args()

    print("reference: hybrid at 1e-10, checked against DOPRI5 at 1e-10", file=sys.stderr)
    reference = model.simulate(p, DURATION, dt=1e-3, tolerance=1e-10).theta
    check = model.simulate(p, DURATION, dt=1e-3, tolerance=1e-10, integrator="dopri5").theta
    print(f"  reference agreement {error(check, reference):.1e}", file=sys.stderr)

    rows = [tighten("piezo_rig.model.simulate", own_simulate, reference, args.budget)]
    tol = rows[0]["tol"]
    wall, _, extra = cli_simulate(args.piezo, tol)
    rows.append({"name": "piezo simulate (process)", "tol": tol, "wall": wall,
                 "steps": extra["steps"], "error": rows[0].get("error")})
    for method in ("LSODA", "Radau", "DOP853"):
        rows.append(tighten(f"SciPy solve_ivp {method}", lambda t, m=method: scipy_solve(m, t),
                            reference, args.budget))
    if not args.skip_octave and shutil.which("octave-cli"):
        for solver in ("ode45", "ode15s"):
            rows.append(tighten(f"Octave {solver}",
                                lambda t, s=solver: octave_solve(s, t, args.budget), reference,
                                args.budget))
    try:
        import numba  # noqa: F401  (python3-numba)
        have_numba = True
    except ImportError:
        have_numba = False
    if have_numba:
        wall, compile_s, theta = numba_rk4(1e-6)
        e = error(theta, reference)
        print(f"  numba RK4 at 1 us: {wall:.3f} s (compiled in {compile_s:.2f} s), error {e:.2e}",
              file=sys.stderr, flush=True)
        rows.append({"name": "numba RK4, fixed 1 us", "tol": 1e-6, "wall": wall, "error": e,
                     "steps": round(DURATION / 1e-6), "rhs_evaluations": 4 * round(DURATION / 1e-6),
                     "tol_text": "h = 1 us"})
    base = rows[0]["wall"]
    print("| solver | tolerance | wall [s] | / piezo_rig | steps | RHS evaluations | error |")
    print("|---|---|---|---|---|---|---|")

    def cell(value, form):
        return "–" if value is None else format(value, form)

    for r in rows:
        if "wall" not in r:
            print(f"| {r['name']} | {r['tol']:g} | – | – | – | – | {r['note']} |")
            continue
        tol_text = r.get("tol_text", format(r["tol"], "g"))
        print(f"| {r['name']} | {tol_text} | {r['wall']:.3f} | {r['wall'] / base:.1f} | "
              f"{cell(r.get('steps'), 'd')} | {cell(r.get('rhs_evaluations'), 'd')} | "
              f"{cell(r.get('error'), '.1e')} |")


if __name__ == "__main__":
    main()
