#!/usr/bin/python3
"""The LuGre model at the Table 1 baseline for 4.8 s, solved the way a
researcher would otherwise solve it -- SciPy's solve_ivp (LSODA, Radau,
DOP853) and GNU Octave's ode45 and ode15s (MATLAB's solvers' twins), each
on the equations of docs/model.md written in its own language -- beside
piezo_rig.model.simulate and `piezo simulate`, one run on one machine.

For each peer the tolerance is tightened (1e-5, 1e-7, 1e-9, 1e-11 relative,
absolute scaled to each state) until the angle is within 1e-4 (relative to
the final angle, at every 1 ms sample) of the converged solution (the
project's hybrid integrator at 1e-10, itself checked against DOPRI5 at
1e-10); the table shows the first tolerance that meets it: wall time,
steps, right-hand-side evaluations, error. A peer that needs more than
--budget seconds for one solve is reported as such.

usage: bench_peers.py PIEZO_BINARY [--budget S] [--skip-octave]
(PYTHONPATH=<build>/python; needs python3-scipy and octave)"""

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
            return {"name": name, "tol": tol, "note": f"failed: {e}"}
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
    base = rows[0]["wall"]
    print("| solver | tolerance | wall [s] | / piezo_rig | steps | RHS evaluations | error |")
    print("|---|---|---|---|---|---|---|")

    def cell(value, form):
        return "–" if value is None else format(value, form)

    for r in rows:
        if "wall" not in r:
            print(f"| {r['name']} | {r['tol']:g} | – | – | – | – | {r['note']} |")
            continue
        print(f"| {r['name']} | {r['tol']:g} | {r['wall']:.3f} | {r['wall'] / base:.1f} | "
              f"{cell(r.get('steps'), 'd')} | {cell(r.get('rhs_evaluations'), 'd')} | "
              f"{cell(r.get('error'), '.1e')} |")


if __name__ == "__main__":
    main()
