"""Run logs as numpy arrays and pandas DataFrames (docs/run-logs.md).

    from piezo_rig.log import open_run
    run = open_run("runs/20261122T010000Z")      # the directory or its run.h5
    run.status, run.summary["cause"]
    run.sensor[["t", "theta"]]                   # a DataFrame
    run.observer["theta_hat"].to_numpy()

Another tool's HDF5 file, or a MATLAB v7.3 .mat (which is HDF5), is read the
way ``piezo identify`` reads it, by naming its datasets:

    run = open_run("bench.mat", t="/data/t", V="/data/u", theta="/data/phi")
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Optional, Union

import h5py
import numpy as np
import pandas as pd

__all__ = ["RunLog", "open_run"]

GROUPS = ("drive", "sensor", "observer")


@dataclass
class RunLog:
    """One run: ``drive``, ``sensor`` and ``observer`` DataFrames (one column
    per dataset of the group; empty when the log has none), ``config`` (the
    effective config: a dict parsed from the log's TOML, empty for another
    tool's file), ``summary`` (the run's ``--json`` summary, or {}),
    ``status`` (``completed``, ``interrupted``, ``failed`` or
    ``incomplete``) and ``stop_cause``, ``attrs`` every root attribute,
    ``path`` the file."""

    path: str
    drive: pd.DataFrame
    sensor: pd.DataFrame
    observer: pd.DataFrame
    config: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    status: str = ""
    stop_cause: str = ""
    attrs: dict = field(default_factory=dict)

    @property
    def model_parameters(self) -> dict:
        """The model's parameters the run used (the log's ``model_parameters``), or {}."""
        return _json_attr(self.attrs, "model_parameters")

    def fit_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(drive_t, drive_V, t, theta) for ``piezo_rig.model.identify``: the
        readings that failed (NaN angle) left out."""
        good = self.sensor["theta"].notna()
        return (self.drive["t"].to_numpy(), self.drive["V"].to_numpy(),
                self.sensor["t"][good].to_numpy(), self.sensor["theta"][good].to_numpy())


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _json_attr(attrs: dict, name: str) -> dict:
    text = attrs.get(name, "")
    try:
        return json.loads(text) if text else {}
    except json.JSONDecodeError:
        return {}


def _group(f: h5py.File, name: str) -> pd.DataFrame:
    if name not in f or not isinstance(f[name], h5py.Group):
        return pd.DataFrame()
    columns = {key: f[name][key][()] for key in f[name]
               if isinstance(f[name][key], h5py.Dataset) and f[name][key].ndim == 1}
    length = min((len(v) for v in columns.values()), default=0)
    return pd.DataFrame({k: v[:length] for k, v in columns.items()})


def _dataset(f: h5py.File, path: str, file: str) -> np.ndarray:
    if path not in f:
        raise KeyError(f"{file}: {path}: no such dataset (datasets: {', '.join(_datasets(f))})")
    # MATLAB stores vectors as 1 x n (or n x 1) matrices.
    return np.asarray(f[path][()], dtype=float).ravel()


def _datasets(f: h5py.File) -> list:
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
    return RunLog(path, drive, sensor, pd.DataFrame())


def open_run(path: Union[str, os.PathLike], *, t: Optional[str] = None,
             V: Optional[str] = None, theta: Optional[str] = None,
             theta_t: Optional[str] = None) -> RunLog:
    """Reads a ``piezo`` run (its directory or ``run.h5``) whole. With
    dataset names (``t``, ``V``, ``theta``, and ``theta_t`` when the angle
    has its own time), reads another tool's HDF5 or MATLAB v7.3 file
    instead: ``drive`` gets t and V, ``sensor`` t and theta. A CSV has the
    columns t, V and theta (or the names given). Every file ``piezo
    identify`` accepts. Raises ``FileNotFoundError``, or ``KeyError``
    naming a missing dataset or column."""
    path = os.fspath(path)
    if os.path.isdir(path):
        path = os.path.join(path, "run.h5")
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such log")
    if path.endswith(".csv"):
        return _csv(path, t, V, theta)
    with h5py.File(path, "r") as f:
        attrs = {k: _text(v) for k, v in f.attrs.items()}
        if t is not None or V is not None or theta is not None:
            if t is None or V is None or theta is None:
                raise KeyError(f"{path}: another tool's file needs t, V and theta datasets named")
            drive_t = _dataset(f, t, path)
            drive = pd.DataFrame({"t": drive_t, "V": _dataset(f, V, path)})
            sensor_t = _dataset(f, theta_t, path) if theta_t else drive_t
            sensor = pd.DataFrame({"t": sensor_t, "theta": _dataset(f, theta, path)})
            return RunLog(path, drive, sensor, pd.DataFrame(), attrs=attrs)
        drive, sensor, observer = (_group(f, g) for g in GROUPS)
    config = {}
    if attrs.get("config"):
        import tomllib
        try:
            config = tomllib.loads(attrs["config"])
        except tomllib.TOMLDecodeError:
            config = {}
    return RunLog(path, drive, sensor, observer, config=config,
                  summary=_json_attr(attrs, "summary"), status=attrs.get("status", ""),
                  stop_cause=attrs.get("stop_cause", ""), attrs=attrs)
