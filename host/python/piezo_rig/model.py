"""The motor's LuGre and Coulomb models (docs/model.md), the project's own
C++ at native speed: the same code, checks and messages as ``piezo
simulate``, ``sensitivity``, ``sweep`` and ``identify``. The interpreter
lock is released while the C++ runs.

    from piezo_rig import model
    p = model.Parameters(V0=60)               # Table 1 defaults otherwise
    sim = model.simulate(p, duration=1.0)
    sim.theta[-1], sim.mean_velocity_rad_s

A parameter outside its physical range raises ``ValueError``
(``model.ParameterError``) naming it and the allowed range.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Iterable, Optional, Sequence, Union

import numpy as np

from . import _model
from ._model import FitData, LogLayout, ParameterError, Parameters

__all__ = ["Parameters", "ParameterError", "Simulation", "Fit", "Observation", "simulate",
           "sensitivity", "sobol", "morris", "sweep", "identify", "observe", "parameter_specs",
           "show_progress"]


def show_progress(shown: bool = True) -> None:
    """Whether long work reports how far it is on ``sys.stderr`` (under the
    running cell in a notebook): studies and sweeps count their runs, fits
    their iterations, simulations of more than a second their time. On by
    default; ``show_progress(False)`` silences it."""
    _model.show_progress(shown)

def _parameters(params: Optional[Parameters], overrides: dict) -> Parameters:
    p = Parameters() if params is None else params.copy()
    for name, value in overrides.items():
        if name != "direction" and not any(s["name"] == name for s in parameter_specs()):
            raise ParameterError(f"Parameters: {name}: unknown parameter (allowed: "
                                 + ", ".join(s["name"] for s in parameter_specs()) + ")")
        setattr(p, name, value)
    return p


def parameter_specs() -> list[dict]:
    """Each parameter's name, config section, unit and allowed range."""
    return _model.parameter_specs()


@dataclass
class Simulation:
    """A simulated run from rest, sampled every ``dt``: time t [s], drive V
    [V], stator x [m] and x_dot, rotor theta [rad] and theta_dot, bristle z
    [m] (zero for Coulomb), friction F_f [N]; ``integrator`` its cost."""

    t: np.ndarray
    V: np.ndarray
    x: np.ndarray
    x_dot: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    z: np.ndarray
    F_f: np.ndarray
    theta_end_rad: float
    mean_velocity_rad_s: float
    integrator: dict
    switch_times: np.ndarray
    model: str
    parameters: Parameters

    def to_dataframe(self):
        """The samples as a pandas DataFrame indexed by t."""
        import pandas as pd
        return pd.DataFrame({k: getattr(self, k) for k in
                             ("t", "V", "x", "x_dot", "theta", "theta_dot", "z", "F_f")}).set_index("t")


def simulate(params: Optional[Parameters] = None, duration: float = 4.8, *,
             model: str = "lugre", direction: Optional[str] = None, dt: float = 1e-4,
             tolerance: float = 1e-6, integrator: str = "model_default",
             **overrides: float) -> Simulation:
    """Simulates the motor from rest for ``duration`` seconds (at most an
    hour) and samples it every ``dt``, as ``piezo simulate`` does.

    model: "lugre" or "coulomb"; direction: "forward" or "reverse" (default:
    the parameters'); integrator: "model_default" (hybrid for LuGre, closed
    form for Coulomb), "hybrid", "dopri5" or "closed_form"; tolerance: the
    integrator's, on the scaled state. ``overrides`` set parameters by
    symbol (``simulate(V0=60)``)."""
    p = _parameters(params, overrides)
    out = _model.simulate(p, duration, model, direction or "", dt, tolerance, integrator)
    return Simulation(model=model, parameters=p, **out)


def sensitivity(params: Optional[Parameters] = None, *, model: str = "lugre") -> dict:
    """The paper's section 5 study: V0, f, mu and D at five levels each, 4.8 s
    per level (all cores). Returns ``{"parameters": [{"name", "levels",
    "mean_velocity_rad_s", "elasticity"}, ...], "ranking": [...]}``, as
    ``piezo sensitivity --json``."""
    return json.loads(_model.sensitivity(_parameters(params, {}), model))


def sobol(params: Optional[Parameters] = None, names: Optional[Sequence[str]] = None, *,
          range_pct: float = 10.0, samples: int = 1024, seed: int = 1,
          output: str = "velocity", runtime: float = 4.8, bootstrap: int = 200,
          model: str = "lugre") -> dict:
    """Sobol' indices (first order S1 and total ST, with 95 % bootstrap
    intervals) of the output ("velocity", "step" or "backslip") over the
    parameters ``names`` (default: all of Table 1), each uniform within
    ±``range_pct`` % of its value; ``samples`` (N >= 8) points of a Saltelli
    design, N (k + 2) simulations on all cores. As ``piezo sensitivity
    --method sobol --json``."""
    return json.loads(_model.global_study(_parameters(params, {}), "sobol", list(names or []),
                                          range_pct, samples, seed, output, runtime, bootstrap,
                                          model))


def morris(params: Optional[Parameters] = None, names: Optional[Sequence[str]] = None, *,
           range_pct: float = 10.0, trajectories: int = 20, seed: int = 1,
           output: str = "velocity", runtime: float = 4.8, model: str = "lugre") -> dict:
    """Morris elementary effects (mu, mu*, sigma) over ``trajectories``
    trajectories; otherwise as ``sobol``."""
    return json.loads(_model.global_study(_parameters(params, {}), "morris", list(names or []),
                                          range_pct, trajectories, seed, output, runtime, 0,
                                          model))


def sweep(name: str = "f", values: Iterable[float] = (), params: Optional[Parameters] = None, *,
          periods: int = 20, model: str = "lugre") -> dict:
    """One parameter over ``values`` (e.g. ``np.geomspace(1, 2000, 60)`` for
    f), each point simulated for ``periods`` drive periods: returns numpy
    arrays ``values``, ``mean_velocity_rad_s``, ``step_rad`` (net angle per
    period) and ``backslip_rad`` (backward slip per period), as ``piezo
    sweep``."""
    return _model.sweep(_parameters(params, {}), name, [float(v) for v in values], periods, model)


@dataclass
class Fit:
    """A fit: ``parameters`` the fitted values by name, with
    ``standard_errors`` and 95 % ``confidence_95`` intervals; ``rmse_rad``
    (paper Eq. 7) and where it started; ``fitted`` the whole parameter set
    (a start for ``simulate``); ``theta_fit`` the model at ``data.t``."""

    parameters: dict
    standard_errors: dict
    confidence_95: dict
    rmse_rad: float
    initial_rmse_rad: float
    iterations: int
    samples: int
    notes: list
    fitted: Parameters
    theta_fit: np.ndarray
    model: str
    data: Any = field(repr=False, default=None)


def load_fit_data(log: Union[str, os.PathLike], *, t: str = "", V: str = "", theta: str = "",
                  theta_t: str = "") -> tuple:
    """(FitData, Parameters) of a log as ``identify`` reads it: a ``piezo``
    run.h5 (or its directory), a CSV with t, V, theta columns, or another
    tool's HDF5 / MATLAB v7.3 file with the datasets named by ``t``, ``V``,
    ``theta`` (and ``theta_t`` if the angle has its own time)."""
    path = os.fspath(log)
    if os.path.isdir(path):
        path = os.path.join(path, "run.h5")
    return _model.load_run(path, LogLayout(t, V, theta, theta_t))


def identify(log_or_arrays: Any, params: Optional[Parameters] = None, *,
             free: Sequence[str] = ("sigma0", "sigma1", "F_N", "d_e"), model: str = "lugre",
             max_iterations: int = 40, layout: Optional[dict] = None) -> Fit:
    """Fits ``free`` parameters to a measured run (Levenberg-Marquardt, on
    all cores), as ``piezo identify``.

    log_or_arrays: a log path (see ``load_fit_data``; ``layout`` names another
        tool's datasets: ``{"t": ..., "V": ..., "theta": ...}``), a
        ``piezo_rig.log.RunLog``, or arrays ``(drive_t, drive_V, t, theta)``
        (a dict with those keys too).
    params: the start (default: the log's own parameters, Table 1 for arrays).
    """
    from .log import RunLog
    start = Parameters()
    if isinstance(log_or_arrays, RunLog):
        log_or_arrays = log_or_arrays.path
    if isinstance(log_or_arrays, (str, os.PathLike)):
        data, start = load_fit_data(log_or_arrays, **(layout or {}))
    elif isinstance(log_or_arrays, dict):
        data = FitData(**log_or_arrays)
    else:
        data = FitData(*log_or_arrays)
    if params is not None:
        start = params
    out = _model.identify(start, data, list(free), model, max_iterations)
    return Fit(model=model, data=data, **out)


@dataclass
class Observation:
    """The LuGre observer along a recorded run, one row per angle used:
    ``t`` [s], the corrected estimates ``theta_hat``, ``theta_dot_hat``,
    ``x_hat``, ``z_hat``, ``F_hat``, the ``residual`` (measured minus
    predicted, before the correction) and ``theta_open`` (the model alone);
    ``summary`` the residual's and the open loop's RMS, outliers, restarts."""

    t: np.ndarray
    theta_hat: np.ndarray
    theta_dot_hat: np.ndarray
    x_hat: np.ndarray
    z_hat: np.ndarray
    F_hat: np.ndarray
    residual: np.ndarray
    theta_open: np.ndarray
    summary: dict


def observe(drive_t, drive_V, t, theta, params: Optional[Parameters] = None, *,
            alpha: float = 0.3, beta: float = 0.05, gate_rad: float = 1e-3,
            ramp_time: float = 1e-4, latency: float = 0.0) -> Observation:
    """Runs ``piezo run``'s LuGre observer (docs/analysis.md) on a recorded
    drive (``drive_t`` [s], ``drive_V`` [V]) and measured angle (``t``,
    ``theta``; NaN readings skipped): the same code the host runs beside a
    live run, so on a ``piezo run`` log it gives the log's /observer.

    alpha, beta, gate_rad: the config's ``[observer]`` gains; ramp_time: how
    long the signal chain takes to reach each command (a drive period,
    1 / ``hello["drive_rate_hz"]``); latency: the board's
    ``hello["output_latency_s"]`` (a log's ``drive_latency_s``)."""
    data = FitData(drive_t, drive_V, t, theta, ramp_time)
    out = _model.observe(_parameters(params, {}), data, alpha, beta, gate_rad, latency)
    return Observation(**out)
