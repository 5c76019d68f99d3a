"""A fly scan this client controls (``Board.scan``): a ``Run`` whose
triggers come as the board fires them.

>>> with board.scan(0.01, 0.06, 0.03, axis="theta", trigger_step_rad=0.002) as scan:
...     for pulse in scan.triggers():      # each as the board fires it
...         print(pulse.axis, pulse.k, pulse.angle_rad)
>>> scan.accounts["theta"]["measured_velocity_rad_per_s"]

Its blocks, samples and angles are a ``Run``'s (``scan.theta()``, ...);
``scan.pulses(axis)`` are every pulse of an axis once the scan ended, from
the board's summary (complete even where the stream lost some).
"""

from __future__ import annotations

import collections
from dataclasses import dataclass
from typing import Any, Iterator, Optional

import msgpack

from ._wire import Command, Key, MoveEnd, Topic
from .board import Board, Run
from .errors import RunEnded


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


class Scan(Run):
    """A scan under way (see the module)."""

    def __init__(self, board: Board, args: dict[str, Any]):
        self._fired: collections.deque[Trigger] = collections.deque()
        self._streamed: list[Trigger] = []
        super().__init__(board, Command.scan, args, True, raise_on_fault=False,
                         axis=args.get(Key.axis) or next(iter(args.get(Key.scans) or {}), None))

    def _on_other(self, topic: str, body: bytes) -> None:
        if topic != Topic.trigger:
            return
        event = msgpack.unpackb(body, raw=False)
        if event.get(Key.run) != self.started.get(Key.run):
            return
        trigger = Trigger.of(str(event[Key.axis]), event)
        self._fired.append(trigger)
        self._streamed.append(trigger)

    def triggers(self) -> Iterator[Trigger]:
        """Each pulse as the board fires it, until the scan ended (the
        samples keep coming in beside; ``drive``, ``sensor``, ``theta()``)."""
        while self._summary is None or self._fired:
            if self._fired:
                yield self._fired.popleft()
                continue
            self._pending.clear()  # the blocks are kept in drive/sensor all the same
            self._receive(0.2)

    @property
    def streamed(self) -> list[Trigger]:
        """The pulses the stream brought so far, in the order they came."""
        return list(self._streamed)

    @property
    def accounts(self) -> dict[str, dict[str, Any]]:
        """Each axis's scan by name once it ended (``measured_velocity_rad_per_s``,
        ``ripple_rad_per_s``, ``model_velocity_rad_per_s``, ``triggers``,
        ``stop_cause``, ...; docs/protocol.md, "Scans"); as the board took them before."""
        if self._summary is None:
            return {str(a[Key.axis]): a for a in self.started.get(Key.scans) or []}
        return {str(a[Key.name]): a.get(Key.scan) or {} for a in self._summary[Key.axes]}

    def pulses(self, axis: Optional[str] = None) -> list[Trigger]:
        """Every pulse of ``axis`` (None: the scan's axis), from the board's
        summary: once the scan ended, all it fired."""
        name = axis or self.axis
        return [Trigger.of(name, p) for p in self.accounts.get(name, {}).get(Key.pulses) or []]

    def wait(self) -> dict[str, Any]:
        """Receives the scan to its end and returns its summary; raises
        ``RunEnded`` when an axis did not end its scan (its ``stop_cause``:
        ``stalled``, ``estop``, ``link_lost``, ...)."""
        summary = super().wait()
        missed = {name: a.get(Key.stop_cause) for name, a in self.accounts.items()
                  if a.get(Key.stop_cause) != MoveEnd.on_target}
        if missed:
            raise RunEnded(Command.scan, ", ".join(f"{k}: {v}" for k, v in missed.items()), summary)
        return summary
