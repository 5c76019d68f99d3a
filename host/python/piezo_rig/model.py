"""The motor's LuGre and Coulomb models (docs/model.md), the project's own
C++ at native speed: the same code, checks and figures as ``piezo
simulate``, ``sensitivity``, ``sweep`` and ``identify``. The interpreter
lock is released while the C++ runs.

>>> from piezo_rig import model
>>> p = model.Parameters(V0=60)               # Table 1 defaults otherwise
>>> sim = model.simulate(p, duration=1.0)
>>> bool(sim.theta[-1] == sim.theta_end_rad > 0)
True

A parameter outside its physical range raises ``ValueError``
(``model.ParameterError``) naming it and the allowed range; an argument of
the wrong type raises ``TypeError`` naming it:

>>> model.Parameters(V0=-5)
Traceback (most recent call last):
...
piezo_rig._model.ParameterError: Parameters: V0: value -5.000000 V is outside the allowed range [0, 1000]
>>> model.simulate(p, "1")
Traceback (most recent call last):
...
TypeError: simulate: duration: expected a number (float or int), got str '1'
"""

from __future__ import annotations

import json
import numbers
import os
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Optional, Sequence, TypedDict, Union, cast, overload

import numpy as np

from . import _model, _values
from ._model import FitData, LogLayout, ParameterError, Parameters

__all__ = ["Parameters", "ParameterError", "FitData", "Simulation", "Fit", "TargetFit", "Observation",
           "simulate", "sensitivity", "sobol", "morris", "sweep", "identify", "fit_data",
           "load_fit_data", "observe", "parameter_specs", "show_progress", "SensitivityStudy",
           "LevelRuns", "SobolStudy", "SobolIndex", "MorrisStudy", "MorrisEffect", "Sweep"]


def show_progress(shown: bool = True) -> None:
    """Whether long work reports how far it is on ``sys.stderr`` (under the
    running cell in a notebook): studies and sweeps count their runs, fits
    their iterations, simulations of more than a second their time. On by
    default; ``show_progress(False)`` silences it."""
    _model.show_progress(shown)

def _parameters(function: str, params: Optional[Parameters], overrides: dict[str, Any]) -> Parameters:
    """``params`` (Table 1 when None) with ``overrides`` applied together."""
    if params is None:
        params = Parameters()
    elif not isinstance(params, Parameters):
        raise TypeError(f"{function}: params: expected piezo_rig.model.Parameters, got "
                        f"{type(params).__name__}")
    return params.replace(**overrides) if overrides else params.copy()


def _number(function: str, name: str, value: Any) -> float:
    """``value`` as a float; a TypeError naming the argument otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{function}: {name}: expected a number (float or int), got "
                        f"{type(value).__name__} {value!r}")
    return float(value)


def _integer(function: str, name: str, value: Any) -> int:
    """``value`` as an int; a TypeError naming the argument otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{function}: {name}: expected an integer, got "
                        f"{type(value).__name__} {value!r}")
    return int(value)


def _text(function: str, name: str, value: Any, allowed: Sequence[str]) -> str:
    """``value``, one of ``allowed``: a TypeError or ValueError naming the argument otherwise."""
    if not isinstance(value, str):
        raise TypeError(f"{function}: {name}: expected one of {', '.join(allowed)}, got "
                        f"{type(value).__name__} {value!r}")
    if value not in allowed:
        raise ValueError(f"{function}: {name}: {value!r} (allowed: {', '.join(allowed)})")
    return value


def _array(function: str, name: str, value: Any) -> np.ndarray[Any, Any]:
    """``value`` as a flat float array; a TypeError naming the argument when
    it holds no numbers, a ValueError when it is not one-dimensional."""
    try:
        array = np.ascontiguousarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{function}: {name}: expected an array of numbers, got "
                        f"{type(value).__name__}") from None
    if array.ndim != 1:
        raise ValueError(f"{function}: {name}: {array.ndim} dimensions (allowed: 1, a flat array "
                         f"of {'one value' if array.ndim == 0 else 'values'})")
    return array


def _names(function: str, value: Any) -> list[str]:
    """A list of parameter names; one name may be given as a string."""
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    names = list(value)
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"{function}: names: expected parameter names (str), got "
                            f"{type(name).__name__} {name!r}")
    return names


class LevelRuns(TypedDict):
    """One parameter of ``sensitivity``: its five levels and what each gave."""
    name: str
    levels: list[float]
    mean_velocity_rad_s: list[float]
    elasticity: float


class SensitivityStudy(TypedDict):
    """``sensitivity``'s result; ``ranking`` the names, most influential first."""
    model: str
    runtime_s: float
    parameters: list[LevelRuns]
    ranking: list[str]


class SobolIndex(TypedDict):
    """One parameter of ``sobol``: its range and indices; the intervals are
    None without bootstrap resamples."""
    name: str
    low: float
    high: float
    S1: float
    S1_interval: Optional[list[float]]
    ST: float
    ST_interval: Optional[list[float]]


class SobolStudy(TypedDict):
    method: str
    output: str
    samples: int
    runs: int
    variance: float
    parameters: list[SobolIndex]


class MorrisEffect(TypedDict):
    """One parameter of ``morris``: its elementary effects' mean, mean of
    the absolute values, and spread."""
    name: str
    mu: float
    mu_star: float
    sigma: float


class MorrisStudy(TypedDict):
    method: str
    output: str
    trajectories: int
    runs: int
    parameters: list[MorrisEffect]


class Sweep(TypedDict):
    """``sweep``'s result: numpy arrays, one value a point."""
    values: np.ndarray[Any, Any]
    mean_velocity_rad_s: np.ndarray[Any, Any]
    step_rad: np.ndarray[Any, Any]
    backslip_rad: np.ndarray[Any, Any]


def _json_object(text: str) -> dict[str, Any]:
    """A study's JSON (the CLI's --json, from the same C++) as a dict."""
    value = json.loads(text)
    assert isinstance(value, dict)
    return value


def _study_names(function: str, value: Any) -> list[str]:
    """A study's parameter names: None for all of Table 1; an empty list is
    refused (it read as "all", the opposite of what it says)."""
    names = _names(function, value)
    if value is not None and not names:
        raise ValueError(f"{function}: names: empty (allowed: one or more parameter names, or "
                         "None for all of Table 1)")
    return names


# The choices as the C++ names them (its name tables), not copied here.
MODELS: tuple[str, ...] = _model.NAMES["models"]
DIRECTIONS: tuple[str, ...] = _model.NAMES["directions"]
INTEGRATORS: tuple[str, ...] = _model.NAMES["integrators"]
COLUMNS: tuple[str, ...] = _model.NAMES["columns"]
OUTPUTS: tuple[str, ...] = _model.NAMES["outputs"]


def parameter_specs() -> list[dict[str, Any]]:
    """Each parameter's name, config section, unit and allowed range."""
    return _model.parameter_specs()


@_values.by_value
@dataclass(eq=False)
class Simulation:
    """A simulated run from rest, sampled every ``dt``: time t [s], drive V
    [V], stator x [m] and x_dot, rotor theta [rad] and theta_dot, bristle z
    [m] (zero for Coulomb), friction F_f [N]; ``integrator`` its cost."""

    t: np.ndarray[Any, Any]
    V: np.ndarray[Any, Any]
    x: np.ndarray[Any, Any]
    x_dot: np.ndarray[Any, Any]
    theta: np.ndarray[Any, Any]
    theta_dot: np.ndarray[Any, Any]
    z: np.ndarray[Any, Any]
    F_f: np.ndarray[Any, Any]
    theta_end_rad: float
    mean_velocity_rad_s: float
    integrator: dict[str, Any]
    switch_times: np.ndarray[Any, Any]
    model: str
    parameters: Parameters

    def to_dataframe(self) -> Any:
        """The samples as a pandas DataFrame indexed by t (the columns simulated)."""
        import pandas as pd
        return pd.DataFrame({k: getattr(self, k) for k in COLUMNS
                             if len(getattr(self, k)) == len(self.t)}).set_index("t")


def simulate(params: Optional[Parameters] = None, duration: float = 4.8, *,
             model: str = "lugre", direction: Optional[str] = None, dt: float = 1e-4,
             tolerance: float = 1e-6, integrator: str = "model_default",
             columns: Optional[Sequence[str]] = None, **overrides: float) -> Simulation:
    """Simulates the motor from rest for ``duration`` seconds (at most an
    hour) and samples it every ``dt``, as ``piezo simulate`` does.

    model: "lugre" or "coulomb"; direction: "forward" or "reverse" (default:
    the parameters'); integrator: "model_default" (hybrid for LuGre, closed
    form for Coulomb), "hybrid", "dopri5" or "closed_form"; tolerance: the
    integrator's, on the scaled state (the CLI's default 1e-6); columns: the
    samples wanted, of ``COLUMNS`` (default: all; t and theta always come,
    the others not asked for are empty arrays), so that a study that reads
    theta pays for theta alone. ``overrides`` set parameters by symbol
    (``simulate(V0=60)``).

    >>> sim = simulate(V0=60, duration=0.5)
    >>> len(sim.t), float(sim.t[-1])
    (5001, 0.5)
    """
    p = _parameters("simulate", params, overrides)
    out = _model.simulate(p, _number("simulate", "duration", duration),
                          _text("simulate", "model", model, MODELS),
                          "" if direction is None else _text("simulate", "direction", direction,
                                                             DIRECTIONS),
                          _number("simulate", "dt", dt), _number("simulate", "tolerance", tolerance),
                          _text("simulate", "integrator", integrator, INTEGRATORS),
                          list(COLUMNS) if columns is None else
                          [_text("simulate", "columns", c, COLUMNS) for c in
                           ([columns] if isinstance(columns, str) else list(columns))])
    for name in COLUMNS:
        out.setdefault(name, np.empty(0))  # a column not asked for: empty
    return Simulation(model=model, parameters=p, **out)


def sensitivity(params: Optional[Parameters] = None, *, model: str = "lugre") -> SensitivityStudy:
    """The paper's section 5 study around ``params`` (Table 1 by default):
    V0, f, mu and D at the paper's five levels each, scaled by the ratio of
    their value in ``params`` to Table 1's (at Table 1 the paper's levels),
    4.8 s per level, on all cores. Returns ``{"parameters": [{"name", "levels",
    "mean_velocity_rad_s", "elasticity"}, ...], "ranking": [...]}``, as
    ``piezo sensitivity --json``.

    >>> study = sensitivity(Parameters(V0=60))
    >>> study["parameters"][0]["levels"]
    [54.0, 57.0, 60.0, 63.0, 66.0]
    """
    text = _model.sensitivity(_parameters("sensitivity", params, {}),
                              _text("sensitivity", "model", model, MODELS))
    return cast(SensitivityStudy, _json_object(text))


def sobol(params: Optional[Parameters] = None, names: Optional[Sequence[str]] = None, *,
          range_pct: float = 10.0, samples: int = 1024, seed: int = 1,
          output: str = "velocity", runtime: float = 4.8, bootstrap: int = 200,
          model: str = "lugre") -> SobolStudy:
    """Sobol' indices (first order S1 and total ST, with 95 % bootstrap
    intervals; ``None`` for ``bootstrap`` below 2, which gives no interval)
    of the output ("velocity", "step" or "backslip") over the
    parameters ``names`` (default: all of Table 1), each uniform within
    ±``range_pct`` % of its value; ``samples`` (N >= 8) points of a Saltelli
    design, N (k + 2) simulations on all cores. One name may be given as a
    string. As ``piezo sensitivity --method sobol --json``.

    >>> s = sobol(names=["V0", "f"], samples=8, runtime=0.2, bootstrap=20)
    >>> [p["name"] for p in s["parameters"]], s["runs"]
    (['V0', 'f'], 32)
    """
    return cast(SobolStudy, _json_object(_model.global_study(
        _parameters("sobol", params, {}), "sobol", _study_names("sobol", names),
        _number("sobol", "range_pct", range_pct), _integer("sobol", "samples", samples),
        _integer("sobol", "seed", seed), _text("sobol", "output", output, OUTPUTS),
        _number("sobol", "runtime", runtime), _integer("sobol", "bootstrap", bootstrap),
        _text("sobol", "model", model, MODELS))))


def morris(params: Optional[Parameters] = None, names: Optional[Sequence[str]] = None, *,
           range_pct: float = 10.0, trajectories: int = 20, seed: int = 1,
           output: str = "velocity", runtime: float = 4.8, model: str = "lugre") -> MorrisStudy:
    """Morris elementary effects (mu, mu*, sigma) over ``trajectories``
    trajectories (at least 2); otherwise as ``sobol``."""
    return cast(MorrisStudy, _json_object(_model.global_study(
        _parameters("morris", params, {}), "morris", _study_names("morris", names),
        _number("morris", "range_pct", range_pct),
        _integer("morris", "trajectories", trajectories), _integer("morris", "seed", seed),
        _text("morris", "output", output, OUTPUTS), _number("morris", "runtime", runtime), 0,
        _text("morris", "model", model, MODELS))))


def sweep(name: str = "f", values: Iterable[float] = (), params: Optional[Parameters] = None, *,
          periods: int = 20, model: str = "lugre") -> Sweep:
    """One parameter over ``values`` (e.g. ``np.geomspace(1, 2000, 60)`` for
    f), each point simulated for ``periods`` drive periods: returns numpy
    arrays ``values``, ``mean_velocity_rad_s``, ``step_rad`` (net angle per
    period) and ``backslip_rad`` (backward slip per period), as ``piezo
    sweep``.

    >>> out = sweep("f", [5, 10], periods=5)
    >>> out["values"].tolist(), bool(out["step_rad"][1] > 0)
    ([5.0, 10.0], True)
    """
    if not isinstance(name, str):
        raise TypeError(f"sweep: name: expected a parameter's symbol (str), got {name!r}")
    points = _array("sweep", "values", values)
    if len(points) == 0:
        raise ValueError("sweep: values: empty (allowed: one or more values)")
    return cast(Sweep, _model.sweep(_parameters("sweep", params, {}), name, points.tolist(),
                                    _integer("sweep", "periods", periods),
                                    _text("sweep", "model", model, MODELS)))


@_values.by_value
@dataclass(eq=False)
class Fit:
    """A fit: ``parameters`` the fitted values by name, with
    ``standard_errors`` and 95 % ``confidence_95`` intervals; ``rmse_rad``
    (paper Eq. 7) and where it started; ``fitted`` the whole parameter set
    (a start for ``simulate``); ``theta_fit`` the model at ``data.t``.
    ``converged`` says whether Levenberg-Marquardt met its tolerances and
    ``stop_reason`` why it stopped: a fit stopped by ``max_iterations`` is
    where it stopped, not an optimum, and its intervals mean nothing (the
    first note says so)."""

    parameters: dict[str, Any]
    standard_errors: dict[str, Any]
    confidence_95: dict[str, Any]
    rmse_rad: float
    initial_rmse_rad: float
    iterations: int
    converged: bool
    stop_reason: str
    samples: int
    notes: list[Any]
    fitted: Parameters
    theta_fit: np.ndarray[Any, Any]
    model: str
    data: Any = field(repr=False, compare=False, default=None)


def load_fit_data(log: Union[str, os.PathLike[str]], *, t: str = "", V: str = "", theta: str = "",
                  theta_t: str = "", axis: str = "") -> tuple[Any, ...]:
    """(FitData, Parameters) of a log as ``identify`` reads it: a ``piezo``
    run.h5 (or its directory; ``axis``: the axis of a group move's log), a
    CSV with t, V, theta columns, or another tool's HDF5 / MATLAB v7.3 file
    with the datasets named by ``t``, ``V``, ``theta`` (and ``theta_t`` if
    the angle has its own time)."""
    path = os.fspath(log)
    if os.path.isdir(path):
        path = os.path.join(path, "run.h5")
    return _model.load_run(path, LogLayout(t, V, theta, theta_t, axis))


def fit_data(drive_t: Any, drive_V: Any, t: Any, theta: Any, *,
             ramp_time: Optional[float] = None, function: str = "fit_data") -> FitData:
    """A run as arrays, checked and taken as a log is read (what
    ``identify`` fits): the drive two or more finite samples at
    non-decreasing times (a repeated time left out), the angle's times
    finite and non-decreasing, one angle each (NaN: a failed reading, left
    out). ``ramp_time`` [s]: the drive's median interval unless given.
    Raises ``TypeError`` or ``ValueError`` naming the argument."""
    return FitData(_array(function, "drive_t", drive_t), _array(function, "drive_V", drive_V),
                   _array(function, "t", t), _array(function, "theta", theta),
                   None if ramp_time is None else _number(function, "ramp_time", ramp_time),
                   function)


@_values.by_value
@dataclass(eq=False)
class TargetFit:
    """A fit to reported figures (``identify(targets=...)``): ``parameters``
    the fitted values by name, with ``standard_errors`` and 95 %
    ``confidence_95`` intervals when there are more targets than free
    parameters (else NaN: the fit meets them exactly or not at all);
    ``targets`` how the fit met each, in order (``model_time_s``,
    ``relative_error``, ``initial_model_time_s`` at the start values);
    ``fitted`` the whole parameter set (a start for ``simulate``)."""

    parameters: dict[str, Any]
    standard_errors: dict[str, Any]
    confidence_95: dict[str, Any]
    targets: list[dict[str, Any]]
    iterations: int
    converged: bool
    stop_reason: str
    notes: list[Any]
    fitted: Parameters
    model: str


@overload
def identify(log_or_arrays: Any, params: Optional[Parameters] = None, *,
             free: Optional[Sequence[str]] = None, model: str = "lugre",
             max_iterations: int = 40, layout: Optional[dict[str, Any]] = None) -> Fit: ...


@overload
def identify(log_or_arrays: None = None, params: Optional[Parameters] = None, *,
             free: Optional[Sequence[str]] = None, model: str = "lugre",
             max_iterations: int = 40, layout: Optional[dict[str, Any]] = None,
             targets: Sequence[Mapping[str, float]]) -> TargetFit: ...


def identify(log_or_arrays: Any = None, params: Optional[Parameters] = None, *,
             free: Optional[Sequence[str]] = None, model: str = "lugre",
             max_iterations: int = 40, layout: Optional[dict[str, Any]] = None,
             targets: Optional[Sequence[Mapping[str, float]]] = None) -> Union[Fit, TargetFit]:
    """Fits ``free`` parameters to a measured run (Levenberg-Marquardt, on
    all cores), as ``piezo identify``; or, with ``targets`` instead of a
    run, to figures a paper reports (``piezo identify --target``).

    log_or_arrays: a log path (see ``load_fit_data``; ``layout`` names another
        tool's datasets: ``{"t": ..., "V": ..., "theta": ...}``), a
        ``piezo_rig.log.RunLog`` (``RunLog.fit_arrays()`` gives the same
        fit), a ``FitData`` (``fit_data``'s), or arrays ``(drive_t,
        drive_V, t, theta)`` (a dict with those keys too), checked as
        ``fit_data`` checks them; a board's run gives them as
        ``Run.fit_arrays()``.
    params: the start (default: the log's own parameters, Table 1 for arrays).
    free: the parameters to fit; default the model's: LuGre sigma0, sigma1,
        F_N and d_e, Coulomb F_N and d_e. A parameter the model does not use
        (a bristle's sigma0 under Coulomb) is refused.
    targets: each "the rotor covered ``angle`` rad from rest in ``time`` s"
        with its other keys set as parameters (``{"f": 20, "d_e": 0.228e-6,
        "angle": 0.010, "time": 1.36}``); the angle is read at the drive's
        periods' ends. At most as many ``free`` as targets; a name is
        shared by all, or one target's own with its number (``"d_e@2"``,
        counted from 1). Gives a
        ``TargetFit``; the start is Table 1 unless ``params``. The paper's
        section 4.2 (docs/model.md):

        >>> fit = identify(targets=[{"f": 10, "angle": 0.010, "time": 4.9},
        ...                         {"f": 20, "d_e": 0.228e-6, "angle": 0.010, "time": 1.36}],
        ...                free=["F_N", "d_e"])
        >>> round(fit.parameters["F_N"] * 1e3, 2), round(fit.parameters["d_e"] * 1e6, 3)
        (6.16, 0.383)
        >>> [round(t["model_time_s"], 2) for t in fit.targets]
        [4.9, 1.36]
    """
    if targets is not None:
        if log_or_arrays is not None:
            raise TypeError("identify: give a run or targets, not both")
        return _identify_targets(targets, params, free, model, max_iterations)
    start = Parameters()
    # An opened log (piezo_rig.log.RunLog, which depends on this module and
    # not the other way round) is read from its file, with its layout.
    if hasattr(log_or_arrays, "path") and hasattr(log_or_arrays, "layout"):
        layout = log_or_arrays.layout or layout
        log_or_arrays = log_or_arrays.path
    if isinstance(log_or_arrays, (str, os.PathLike)):
        data, start = load_fit_data(log_or_arrays, **(layout or {}))
    elif isinstance(log_or_arrays, FitData):
        data = log_or_arrays
    elif isinstance(log_or_arrays, dict):
        data = fit_data(**log_or_arrays, function="identify")
    elif isinstance(log_or_arrays, (tuple, list)) and len(log_or_arrays) == 4:
        data = fit_data(*log_or_arrays, function="identify")
    else:
        raise TypeError("identify: log_or_arrays: expected a log's path, a RunLog, a FitData, "
                        "or arrays "
                        f"(drive_t, drive_V, t, theta); got {type(log_or_arrays).__name__}")
    if params is not None:
        start = _parameters("identify", params, {})
    names = None if free is None else _names("identify", free)
    out = _model.identify(start, data, names, _text("identify", "model", model, MODELS),
                          _integer("identify", "max_iterations", max_iterations))
    return Fit(model=model, data=data, **out)


def _identify_targets(targets: Sequence[Mapping[str, float]], params: Optional[Parameters],
                      free: Optional[Sequence[str]], model: str,
                      max_iterations: int) -> TargetFit:
    start = Parameters() if params is None else _parameters("identify", params, {})
    parsed = []
    for i, target in enumerate(targets):
        if not isinstance(target, Mapping) or "angle" not in target or "time" not in target:
            raise ValueError(f"identify: targets[{i}]: a mapping with angle, time and the "
                             "parameters it ran with, e.g. {\"f\": 20, \"angle\": 0.010, "
                             "\"time\": 1.36}")
        settings = {str(k): _number("identify", f"targets[{i}].{k}", v)
                    for k, v in target.items() if k not in ("angle", "time")}
        parsed.append((settings, _number("identify", f"targets[{i}].angle", target["angle"]),
                       _number("identify", f"targets[{i}].time", target["time"])))
    names = None if free is None else _names("identify", free)
    out = _model.fit_travel_targets(start, parsed, names,
                                    _text("identify", "model", model, MODELS),
                                    _integer("identify", "max_iterations", max_iterations))
    for key in ("rmse_rad", "initial_rmse_rad", "samples", "theta_fit"):
        out.pop(key)
    return TargetFit(model=model, **out)


@_values.by_value
@dataclass(eq=False)
class Observation:
    """The LuGre observer along a recorded run, one row per angle used:
    ``t`` [s], the corrected estimates ``theta_hat``, ``theta_dot_hat``,
    ``x_hat``, ``z_hat``, ``F_hat``, the ``residual`` (measured minus
    predicted, before the correction) and ``theta_open`` (the model alone);
    ``summary`` the residual's and the open loop's RMS, outliers, restarts."""

    t: np.ndarray[Any, Any]
    theta_hat: np.ndarray[Any, Any]
    theta_dot_hat: np.ndarray[Any, Any]
    x_hat: np.ndarray[Any, Any]
    z_hat: np.ndarray[Any, Any]
    F_hat: np.ndarray[Any, Any]
    residual: np.ndarray[Any, Any]
    theta_open: np.ndarray[Any, Any]
    summary: dict[str, Any]


def observe(drive_t: Any, drive_V: Any, t: Any, theta: Any,
            params: Optional[Parameters] = None, *,
            alpha: float = _model.OBSERVER_GAINS["alpha"],
            beta: float = _model.OBSERVER_GAINS["beta"],
            gate_rad: float = _model.OBSERVER_GAINS["gate_rad"], ramp_time: float = 1e-4,
            latency: float = 0.0) -> Observation:
    """Runs ``piezo run``'s LuGre observer (docs/analysis.md) on a recorded
    drive (``drive_t`` [s], ``drive_V`` [V]) and measured angle (``t``,
    ``theta``; NaN readings skipped): the same code the host runs beside a
    live run, so on a ``piezo run`` log, with that run's gains, ramp and
    latency, it gives the log's /observer bit for bit
    (``piezo_rig.log.RunLog.observe`` passes them).

    The arrays are one-dimensional, finite (theta may hold NaN), their
    times non-decreasing, ``drive_V`` as long as ``drive_t`` and ``theta``
    as ``t``: anything else raises ``ValueError`` naming the argument.
    alpha, beta, gate_rad: the config's ``[observer]`` gains; ramp_time: how
    long the signal chain takes to reach each command (a drive period,
    1 / ``hello["drive_rate_hz"]``); latency: the board's
    ``hello["output_latency_s"]`` (a log's ``drive_latency_s``)."""
    f = "observe"
    return Observation(**_model.observe(
        _parameters(f, params, {}), _array(f, "drive_t", drive_t), _array(f, "drive_V", drive_V),
        _array(f, "t", t), _array(f, "theta", theta), _number(f, "ramp_time", ramp_time),
        _number(f, "alpha", alpha), _number(f, "beta", beta), _number(f, "gate_rad", gate_rad),
        _number(f, "latency", latency)))
