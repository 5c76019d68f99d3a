"""A scan's trigger pulse as the board fired it (docs/protocol.md, "Scans"):
what ``Board.scan``'s ``triggers()`` yields and ``pulses()`` lists."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ._wire import Key


@dataclass(frozen=True)
class Trigger:
    """One pulse as the board fired it: position ``k`` (from 0) at
    ``position_rad``, passed by the filtered measured angle ``angle_rad``
    read at ``reading_s``, its edge at ``edge_s`` (both from the run's
    ``t0_ns``), ``late`` when its reading passed more than one position or
    it waited for the pulse before it."""

    axis: str
    k: int
    position_rad: float
    angle_rad: float
    reading_s: float
    edge_s: float
    late: bool

    @classmethod
    def of(cls, axis: str, pulse: dict[str, Any]) -> "Trigger":
        return cls(axis, int(pulse[Key.k]), float(pulse[Key.position_rad]),
                   float(pulse[Key.angle_rad]), float(pulse[Key.reading_s]),
                   float(pulse[Key.edge_s]), bool(pulse[Key.late]))
