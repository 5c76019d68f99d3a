"""Run logs as numpy arrays and pandas DataFrames (docs/run-logs.md).

>>> from piezo_rig.log import open_run
>>> run = open_run("runs/first")              # the directory or its run.h5
>>> run.status, run.summary["stop_cause"]
('completed', 'completed')
>>> list(run.sensor.columns)                  # DataFrames, one column per dataset
['displacement_m', 'status', 't', 't_received', 't_response', 'theta']
>>> type(run.attrs["drive_latency_s"])        # attributes in their types
<class 'float'>

A group move's log keeps each axis apart; ``open_run(path, axis="phi")``
reads one (``RunLog.axes`` names them all).

Another tool's HDF5 file, or a MATLAB v7.3 .mat (which is HDF5), is read the
way ``piezo identify`` reads it, by naming its datasets:
``open_run("bench.mat", t="/data/t", V="/data/u", theta="/data/phi")``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Optional, Union

import h5py
import numpy as np
import pandas as pd

from . import _values

__all__ = ["RunLog", "open_run"]

GROUPS = ("drive", "sensor", "observer")


@_values.by_value
@dataclass(eq=False)
class RunLog:
    """One run: ``drive``, ``sensor`` and ``observer`` DataFrames (one column
    per dataset of the group; empty when the log has none), ``config`` (the
    effective config: a dict parsed from the log's TOML, empty for another
    tool's file), ``summary`` (the run's ``--json`` summary, or {}),
    ``status`` (``completed``, ``interrupted``, ``failed`` or
    ``incomplete``) and ``stop_cause``, ``attrs`` every root attribute in
    its type (numbers as int or float, JSON maps and lists parsed, other
    text as str), ``path`` the file, ``layout`` the dataset or column
    names another tool's file was read with ({} for a ``piezo`` log written
    before /axes; else the ``axis`` read). ``axes`` names the run's axes
    (one or several; empty for a log written before /axes), ``axis`` the
    one read: its frames, summary, stop cause and parameters are that
    axis's own."""

    path: str
    drive: pd.DataFrame
    sensor: pd.DataFrame
    observer: pd.DataFrame
    config: dict[str, Any] = field(default_factory=dict[str, Any])
    summary: dict[str, Any] = field(default_factory=dict[str, Any])
    status: str = ""
    stop_cause: str = ""
    attrs: dict[str, Any] = field(default_factory=dict[str, Any])
    layout: dict[str, Any] = field(default_factory=dict[str, Any])
    axes: list[str] = field(default_factory=list[str])
    axis: str = ""
    #: A scan's trigger pulses (k, position_rad, angle_rad, reading_s,
    #: edge_s, late), one row per pulse in k's order; empty for any other run.
    triggers: pd.DataFrame = field(default_factory=pd.DataFrame)

    @property
    def model_parameters(self) -> dict[str, Any]:
        """The model's parameters the run used (the log's ``model_parameters``), or {}."""
        value = self.attrs.get("model_parameters", {})
        return value if isinstance(value, dict) else {}

    @property
    def parameters(self) -> Any:
        """The run's model parameters as a ``piezo_rig.model.Parameters``
        (Table 1 where the log has none): the start ``identify(run)`` takes."""
        from .model import Parameters
        return Parameters.from_json(json.dumps(self.model_parameters)) \
            if self.model_parameters else Parameters()

    def fit_arrays(self) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any], np.ndarray[Any, Any], np.ndarray[Any, Any]]:
        """(drive_t, drive_V, t, theta) as ``piezo_rig.model.identify`` reads
        this log (the same reader): the drive shifted by the run's recorded
        latency, a repeated drive time and the failed readings (NaN angle)
        left out. ``identify(run.fit_arrays(), run.parameters)`` is
        ``identify(run)``: the same data, ramp and start."""
        from .model import load_fit_data
        data, _ = load_fit_data(self.path, **self.layout)
        return data.drive_t, data.drive_V, data.t, data.theta

    def observe(self) -> Any:
        """``piezo_rig.model.observe`` on this run as ``piezo run`` ran its
        observer beside it: the run's parameters, its config's
        ``[observer]`` gains, a drive period as the ramp and the drive's
        recorded latency, so the rows are the log's /observer bit for bit."""
        from . import model
        gains = self.config.get("observer", {})
        return model.observe(
            self.drive["t"], self.drive["V"], self.sensor["t"], self.sensor["theta"],
            self.parameters,
            # The config's gains, else the observer's defaults (observe's own).
            **{key: gains[key] for key in ("alpha", "beta", "gate_rad") if key in gains},
            ramp_time=1 / self.config.get("drive", {}).get("rate_hz", 10000.0),
            latency=self.attrs.get("drive_latency_s", 0.0))


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _typed(value: Any) -> Any:
    """An attribute in its type: the log keeps every one as text (numbers,
    JSON maps); another tool's file may hold numbers and arrays."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic) and not isinstance(value, (np.bytes_, np.str_)):
        return value.item()
    text = _text(value)
    for parse in (int, float):
        try:
            return parse(text)
        except ValueError:
            pass
    if text[:1] in ("{", "["):
        try:
            return json.loads(text)
        except json.JSONDecodeError:
            pass
    return text


def _group(f: h5py.File, name: str) -> pd.DataFrame:
    if name not in f or not isinstance(f[name], h5py.Group):
        return pd.DataFrame()
    columns = {key: f[name][key][()] for key in f[name]
               if isinstance(f[name][key], h5py.Dataset) and f[name][key].ndim == 1}
    length = min((len(v) for v in columns.values()), default=0)
    return pd.DataFrame({k: v[:length] for k, v in columns.items()})


def _dataset(f: h5py.File, path: str, file: str) -> np.ndarray[Any, Any]:
    if path not in f:
        raise KeyError(f"{file}: {path}: no such dataset (datasets: {', '.join(_datasets(f))})")
    # MATLAB stores vectors as 1 x n (or n x 1) matrices.
    return np.asarray(f[path][()], dtype=float).ravel()


def _datasets(f: h5py.File) -> list[Any]:
    names = []
    f.visititems(lambda name, obj: names.append("/" + name) if isinstance(obj, h5py.Dataset) else None)
    return names


def _csv(path: str, t: Optional[str], V: Optional[str], theta: Optional[str]) -> RunLog:
    # round_trip: the numbers as written (pandas' fast parser is off in the last bits).
    table = pd.read_csv(path, float_precision="round_trip")
    names = {"t": t or "t", "V": V or "V", "theta": theta or "theta"}
    for role, column in names.items():
        if column not in table:
            raise KeyError(f"{path}: {column}: no such column (columns: {', '.join(table)})")
    drive = pd.DataFrame({"t": table[names["t"]], "V": table[names["V"]]})
    sensor = pd.DataFrame({"t": table[names["t"]], "theta": table[names["theta"]]})
    layout = {role: column for role, column, given in
              (("t", names["t"], t), ("V", names["V"], V), ("theta", names["theta"], theta))
              if given}
    return RunLog(path, drive, sensor, pd.DataFrame(), layout=layout)


def _paired(path: str, role: str, times: tuple[Any, ...], values: tuple[Any, ...], hint: str = "") -> dict[str, Any]:
    """``{"t": times, role: values}`` for a DataFrame; a ValueError naming
    both datasets and their lengths when they differ (columns of two time
    bases paired by index would squeeze one into the other's span).
    ``times`` and ``values`` are (dataset name, array) pairs."""
    (times_name, times_data), (values_name, values_data) = times, values
    if len(times_data) != len(values_data):
        raise ValueError(f"{path}: {values_name} has {len(values_data)} values against "
                         f"{len(times_data)} times in {times_name}{hint}")
    return {"t": times_data, role: values_data}


def open_run(path: Union[str, os.PathLike[str]], *, t: Optional[str] = None,
             V: Optional[str] = None, theta: Optional[str] = None,
             theta_t: Optional[str] = None, axis: Optional[str] = None) -> RunLog:
    """Reads a ``piezo`` run (its directory or ``run.h5``) whole. With
    dataset names (``t``, ``V``, ``theta``, and ``theta_t`` when the angle
    has its own time), reads another tool's HDF5 or MATLAB v7.3 file
    instead: ``drive`` gets t and V, ``sensor`` t and theta. A CSV has the
    columns t, V and theta (or the names given). Every file ``piezo
    identify`` accepts. A group move's log holds several axes: ``axis``
    names the one to read (required there). Raises ``FileNotFoundError``,
    or ``KeyError`` naming a missing dataset or column, or an axis the log
    lacks (listing those it holds)."""
    path = os.fspath(path)
    if os.path.isdir(path):
        path = os.path.join(path, "run.h5")
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such log")
    if path.endswith(".csv"):
        return _csv(path, t, V, theta)
    with h5py.File(path, "r") as f:
        attrs = {k: _typed(v) for k, v in f.attrs.items()}
        if t is not None or V is not None or theta is not None:
            if t is None or V is None or theta is None:
                raise KeyError(f"{path}: another tool's file needs t, V and theta datasets named")
            drive_t = _dataset(f, t, path)
            drive = pd.DataFrame(_paired(path, "V", (t, drive_t), (V, _dataset(f, V, path))))
            sensor_t = _dataset(f, theta_t, path) if theta_t else drive_t
            own_times = "" if theta_t else " (an angle sampled at other times needs its own: theta_t=)"
            sensor = pd.DataFrame(_paired(path, "theta", (theta_t or t, sensor_t),
                                          (theta, _dataset(f, theta, path)), own_times))
            layout = {"t": t, "V": V, "theta": theta, "theta_t": theta_t or ""}
            return RunLog(path, drive, sensor, pd.DataFrame(), attrs=attrs, layout=layout)
        axes = [a for a in _text(f.attrs.get("axes", "")).split(",") if a]
        prefix = _axis_group(path, axes, _text(f.attrs.get("axis", "")), axis)
        if prefix:
            # The axis's own attributes over the log's.
            attrs.update({k: _typed(v) for k, v in f[prefix].attrs.items()})
        drive, sensor, observer = (_group(f, prefix + g) for g in GROUPS)
        triggers = _group(f, prefix + "triggers")
    if not triggers.empty:
        # Streamed as fired; a pulse the stream lost was added at the end.
        triggers = triggers.sort_values("k", ignore_index=True)
    config = {}
    if isinstance(attrs.get("config"), str):
        import tomllib
        try:
            config = tomllib.loads(attrs["config"])
        except tomllib.TOMLDecodeError:
            config = {}
    summary = attrs.get("summary", {})
    return RunLog(path, drive, sensor, observer, config=config,
                  summary=summary if isinstance(summary, dict) else {},
                  status=str(attrs.get("status", "")), stop_cause=str(attrs.get("stop_cause", "")),
                  attrs=attrs, layout={"axis": axis or axes[0]} if prefix else {}, axes=axes,
                  axis=axis or (axes[0] if axes else _text(attrs.get("axis", ""))),
                  triggers=triggers)


def _axis_group(path: str, axes: list[str], own: str, axis: Optional[str]) -> str:
    """The group ``axis`` is kept under: "axes/NAME/", a log of one axis as
    of several (docs/run-logs.md); None names a log's one axis. A log
    written before that layout (no ``axes`` attribute) kept its one axis
    at the root: "" (its ``axis`` attribute, ``own``, names it)."""
    if not axes:
        if axis and axis != own:
            raise KeyError(f"{path}: axis: {axis!r}: the log holds one axis, "
                           + (own or "unnamed (drop axis=)"))
        return ""
    if axis is None and len(axes) == 1:
        return f"axes/{axes[0]}/"
    if axis in axes:
        return f"axes/{axis}/"
    held = ", ".join(axes)
    raise KeyError(f"{path}: axis: " + (f"{axis!r} is not an axis of the log (it holds {held})"
                                        if axis else
                                        f"required: the log holds several axes ({held})"))
