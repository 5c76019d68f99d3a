"""One follower of a board's stream per ``Board`` (``Board.follower``): a
thread that subscribes to the board's stream and keeps what the board says
as immutable snapshots -- its state, fault, health and last run, and each
axis's position, noise, age, moves at rest and fault -- swapped whole under
a lock. ``Run``, ``Axis.status()`` and the Tango bridge all read it.

Angles come from the stream: during a run from its sensor records, between
runs from the board's readings at rest (the ``health`` beat's ``rest``,
docs/protocol.md "At rest"). ``status`` is asked only when the stream is
quiet or says something changed. Every error of the follower's own is
caught: the board then shows as unreachable with the reason, and the
follower starts over (a new socket, ``hello`` and ``status`` again) until
the board answers. A board that restarted is a new board: nothing known of
the old start is kept, and its ``Board`` forgets it too.
"""

from __future__ import annotations

import dataclasses
import queue
import threading
import time
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Optional, Protocol, TypeVar

import msgpack
import numpy as np
import zmq

from ._wire import Key, Topic
from .frames import FrameError, Layout



class Client(Protocol):
    """What the follower asks of its own client of the board (a ``Board``)."""

    def hello(self) -> dict[str, Any]: ...

    def describe(self) -> dict[str, Any]: ...

    def status(self) -> dict[str, Any]: ...

    @property
    def frame_layout(self) -> Layout: ...

    def _socket_for(self, kind: int) -> zmq.Socket[bytes]: ...

    def close(self) -> None: ...

#: How long the stream may be quiet before the board is asked (its health
#: beat comes every 250 ms).
QUIET_S = 1.0
#: After a failure of its own, the follower starts over this much later.
RETRY_S = 0.2

_EMPTY: Mapping[str, Any] = MappingProxyType({})


@dataclass(frozen=True)
class AxisSnapshot:
    """One axis as the board last said (``Board.axes[name].status()``)."""
    name: str
    index: int
    r2_m: float  #: its sensor's radius: its angles are displacements over it
    V_max: float
    travel_min_rad: Optional[float] = None
    travel_max_rad: Optional[float] = None
    #: From its zero: the latest reading in a run, the mean of the latest
    #: readings at rest between runs; None before the board has one.
    position_rad: Optional[float] = None
    zero_displacement_m: Optional[float] = None
    noise_rad: Optional[float] = None  #: one reading's noise at rest
    age_s: Optional[float] = None      #: of the board's latest reading, as it last said
    moved_rad: float = 0.0             #: moved at rest since its last run ended
    moved: bool = False                #: a move at rest was reported since then
    stale: bool = False                #: between runs, its sensor does not answer
    calibrated: bool = False
    fault: Optional[str] = None        #: its own latched fault
    in_run: bool = False               #: a run of the board drives it now
    move: Mapping[str, Any] = field(default_factory=lambda: _EMPTY)  #: the move's progress, while one is under way


@dataclass(frozen=True)
class BoardSnapshot:
    """The board as the follower last heard it (``Board.follower.snapshot``)."""
    reachable: bool = False
    problem: str = "not yet heard from"  #: why it is unreachable ("" when it is not)
    board_id: Optional[str] = None
    generation: int = 0  #: counts the board starts seen
    state: str = "unknown"
    fault: Optional[str] = None
    health: Mapping[str, Any] = field(default_factory=lambda: _EMPTY)  #: the live `drive`/`sensor` counters, a move's `moves`
    last_summary: Mapping[str, Any] = field(default_factory=lambda: _EMPTY)
    axes: Mapping[str, AxisSnapshot] = field(default_factory=lambda: _EMPTY)  #: in the board's order
    moved: tuple[Mapping[str, Any], ...] = ()  #: the `moved` events of this board start
    rejected_frames: int = 0  #: malformed or unexpected messages on the stream, dropped


Listener = Callable[[BoardSnapshot], None]


class Follower:
    """Follows the board's stream at ``stream`` with ``watch``, a client of
    its own (a board that does not answer never holds up the caller's stop
    or e-stop behind a status request); ``new_board()`` is called when it
    sees the board restarted. Started by ``Board.follower``; ended by
    ``Board.close``."""

    def __init__(self, address: str, stream: str, watch: Client, stream_queue: int,
                 new_board: Callable[[], None]):
        self._address, self._stream, self._queue_size = address, stream, stream_queue
        self._new_board = new_board
        self._watch = watch
        self._lock = threading.Lock()
        self._snapshot = BoardSnapshot()
        self._hello: dict[str, Any] = {}
        self._layout: Optional[Layout] = None
        # Each event's keys that every one of it holds (the board's dictionary).
        self._always: dict[str, frozenset[str]] = {}
        self._listeners: list[Listener] = []
        self._queues: list[queue.SimpleQueue[Any]] = []
        self._sub: Optional[zmq.Socket[bytes]] = None
        self._heard = 0.0
        self._streaming = threading.Event()  # the current socket has had a message
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._follow, name="piezo_rig follower",
                                        daemon=True)
        self._thread.start()

    # -- for its readers ---------------------------------------------------
    @property
    def hello(self) -> dict[str, Any]:
        """The board's hello as the follower last read it ({} while unreachable)."""
        return self._hello

    @property
    def snapshot(self) -> BoardSnapshot:
        with self._lock:
            return self._snapshot

    def wait_until_heard(self, seconds: float) -> BoardSnapshot:
        """The snapshot once the board was heard (at most ``seconds`` on)."""
        deadline = time.monotonic() + seconds
        while not self.snapshot.reachable and time.monotonic() < deadline:
            time.sleep(0.02)
        return self.snapshot

    def wait_for_stream(self, seconds: float) -> bool:
        """Whether the stream brought a message within ``seconds``: what the
        board publishes from then on reaches the follower (a PUB socket drops
        what it sends before a subscription reaches it)."""
        return self._streaming.wait(seconds)

    def listen(self, listener: Listener) -> None:
        """``listener(snapshot)`` is called from the follower's thread at
        every change; an exception of its own is its own (ignored here)."""
        with self._lock:
            self._listeners.append(listener)

    def forget(self, listener: Listener) -> None:
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)

    def messages(self) -> "queue.SimpleQueue[Any]":
        """A queue of every (topic, body) the stream brings from now on, for
        a run's records; None in it: the follower ended. ``drop`` it after."""
        q: queue.SimpleQueue[Any] = queue.SimpleQueue()
        with self._lock:
            self._queues.append(q)
        return q

    def drop(self, q: "queue.SimpleQueue[Any]") -> None:
        with self._lock:
            if q in self._queues:
                self._queues.remove(q)

    def refresh(self) -> BoardSnapshot:
        """Asks the board's status now (after a command that changed it)."""
        self._ask()
        return self.snapshot

    def close(self) -> None:
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(5)

    # -- the snapshot ------------------------------------------------------
    def _swap(self, **changes: Any) -> None:
        with self._lock:
            self._snapshot = dataclasses.replace(self._snapshot, **changes)
            listeners = list(self._listeners)
            snapshot = self._snapshot
        for listener in listeners:
            try:
                listener(snapshot)
            except Exception:  # a listener's failure is its own; the follower goes on
                pass

    def _axes(self, change: Callable[[AxisSnapshot], Optional[dict[str, Any]]]) -> dict[str, Any]:
        """The axes with ``change(axis)``'s fields replaced, for ``_swap``."""
        axes = {}
        for name, a in self.snapshot.axes.items():
            c = change(a)
            axes[name] = dataclasses.replace(a, **c) if c else a
        return dict(axes=MappingProxyType(axes))

    def _lost(self, why: str) -> None:
        self._hello = {}
        s = self.snapshot
        if s.reachable or s.problem != why:
            self._swap(reachable=False, problem=why, state="unknown")

    # -- what the board says -----------------------------------------------
    def _introduce(self) -> None:
        """hello and the frame layout, once per (re)connection. A board that
        restarted is a new board: nothing known of the old start is kept."""
        hello = self._watch.hello()
        self._layout = self._watch.frame_layout
        self._always = {name: frozenset(f[Key.name] for f in fields if f[Key.always])
                        for name, fields in self._watch.describe()[Key.messages].items()}
        s = self.snapshot
        same = hello.get(Key.board_id) == s.board_id
        if not same:
            self._new_board()  # its next request names the new start
        axes = {}
        for index, a in enumerate(hello[Key.axes]):
            old = s.axes.get(a[Key.name]) if same else None
            axes[a[Key.name]] = AxisSnapshot(
                name=a[Key.name], index=index, r2_m=float(a[Key.r2_m]), V_max=float(a[Key.V_max]),
                travel_min_rad=a.get(Key.travel_min_rad), travel_max_rad=a.get(Key.travel_max_rad),
                position_rad=old.position_rad if old else None)
        self._hello = hello
        changes: dict[str, Any] = dict(board_id=hello.get(Key.board_id),
                                   axes=MappingProxyType(axes))
        if not same:
            changes.update(generation=s.generation + 1, last_summary=_EMPTY, health=_EMPTY,
                           moved=())
        self._swap(**changes)

    def _take_status(self, status: dict[str, Any]) -> None:
        run = status.get(Key.run) or {}
        running = bool(run) and not run.get(Key.finished, False)
        in_run = set(run.get(Key.axes) or []) if running else set()
        entries = {e[Key.name]: e for e in status.get(Key.axes, [])}

        def change(a: AxisSnapshot) -> Optional[dict[str, Any]]:
            e = entries.get(a.name)
            if e is None:
                return None
            position = e.get(Key.position) or {}
            c = dict(zero_displacement_m=position.get(Key.zero_displacement_m),
                     calibrated=bool(e.get(Key.calibrated)), fault=e.get(Key.fault),
                     in_run=a.name in in_run,
                     move=MappingProxyType(next((m for m in run.get(Key.moves) or []
                                                 if m[Key.axis] == a.name), {})))
            if a.name not in in_run and position.get(Key.position_rad) is not None:
                c.update(position_rad=float(position[Key.position_rad]))
            c.update(_rest_fields(e.get(Key.rest)))
            return c

        changes = self._axes(change)
        changes.update(state=str(status[Key.state]), fault=status.get(Key.fault),
                       reachable=True, problem="")
        if run.get(Key.summary):
            changes["last_summary"] = MappingProxyType(run[Key.summary])
        self._swap(**changes)

    def _ask(self) -> bool:
        try:
            if not self._hello:
                self._introduce()
            status = self._watch.status()
            if status.get(Key.board_id) != self.snapshot.board_id:  # restarted since hello
                self._introduce()
                status = self._watch.status()
            self._take_status(status)
            return True
        except Exception as e:  # no reply, or one that is not the protocol's
            self._lost(f"no good reply from the board at {self._address}: "
                       f"{type(e).__name__}: {e}")
            return False

    def _on_sensor(self, records: np.ndarray[Any, Any]) -> None:
        good = records[records[Key.status] == 0]
        latest = {int(i): float(good[good[Key.axis] == i][Key.displacement_m][-1])
                  for i in np.unique(good[Key.axis])}

        def change(a: AxisSnapshot) -> Optional[dict[str, Any]]:
            d = latest.get(a.index)
            if d is None or a.zero_displacement_m is None:
                return None
            return dict(position_rad=angle_rad(d, a.zero_displacement_m, a.r2_m))

        self._swap(**self._axes(change))

    def _on_event(self, topic: str, event: dict[str, Any]) -> None:
        s = self.snapshot
        if event.get(Key.board_id, s.board_id) != s.board_id:
            self._hello = {}  # a new board start: introduced afresh
            self._ask()
            return
        if topic == Topic.trigger:
            return  # a scan's pulse: its Run takes it from its queue
        changed = event.get(Key.state) != s.state or Key.summary in event
        changes: dict[str, Any] = {}
        if Key.summary in event:
            changes["last_summary"] = MappingProxyType(event[Key.summary])
        if topic == Topic.health:
            changes[Key.health] = MappingProxyType(
                {k: event[k] for k in (Key.drive, Key.sensor, Key.moves) if k in event})
            rests = {r[Key.name]: r for r in event.get(Key.rest) or []}

            def change(a: AxisSnapshot) -> Optional[dict[str, Any]]:
                r = rests.get(a.name)
                if r is None:
                    return None
                c = _rest_fields(r)
                if not a.in_run and r.get(Key.position_rad) is not None:
                    c.update(position_rad=float(r[Key.position_rad]))
                return c

            changes.update(self._axes(change))
        if topic == Topic.moved:
            changes[Key.moved] = s.moved + (MappingProxyType(event),)
            rest = event.get(Key.rest) or {}
            changes.update(self._axes(lambda a: (
                dict(_rest_fields(rest), position_rad=rest.get(Key.position_rad))
                if a.name == event.get(Key.axis) else None)))
        self._swap(**changes)
        if changed or not s.reachable:
            self._ask()  # the state, each axis's fault and position, at once

    # -- the thread ----------------------------------------------------------
    def _open(self) -> zmq.Socket[bytes]:
        sub = self._watch._socket_for(zmq.SUB)
        sub.setsockopt(zmq.RCVHWM, self._queue_size)
        sub.connect(self._stream)
        sub.setsockopt(zmq.SUBSCRIBE, b"")
        return sub

    def _close_socket(self) -> None:
        self._streaming.clear()
        if self._sub is not None:
            self._sub.close()
            self._sub = None

    def _turn(self, asked: list[float]) -> None:
        if self._sub is None:
            self._sub = self._open()
        now = time.monotonic()
        if now - self._heard > QUIET_S and now - asked[0] > QUIET_S:
            asked[0] = now
            if self._ask():
                self._heard = now
        if not self._sub.poll(100):
            return
        parts = self._sub.recv_multipart()
        self._heard = time.monotonic()
        self._streaming.set()
        if len(parts) != 2:
            self._swap(rejected_frames=self.snapshot.rejected_frames + 1)
            return
        topic, body = parts[0].decode(errors="replace"), parts[1]
        with self._lock:
            queues = list(self._queues)
        for q in queues:
            q.put((topic, body))
        try:
            if topic == Topic.sensor and self._layout is not None:
                self._on_sensor(self._layout.decode(body)[2])
            elif topic in (Topic.state, Topic.health, Topic.moved, Topic.trigger):
                event = msgpack.unpackb(body, raw=False)
                if not isinstance(event, dict):
                    raise ValueError(f"a {topic} event that is not a map")
                lacking = self._always.get(topic, frozenset()) - event.keys()
                if lacking:
                    raise ValueError(f"a {topic} event without {', '.join(sorted(lacking))}")
                self._on_event(topic, event)
            elif topic != Topic.drive:
                raise ValueError(f"unexpected topic {topic[:32]!r}")
        except (FrameError, ValueError, KeyError, TypeError, IndexError,
                msgpack.exceptions.ExtraData) as e:
            # Dropped and counted; the board is still talking.
            del e
            self._swap(rejected_frames=self.snapshot.rejected_frames + 1)

    def _follow(self) -> None:
        try:
            import tango  # the bridge's pushes from this thread need omniORB's blessing
            ensure: Any = tango.EnsureOmniThread()
        except (ImportError, AttributeError):
            ensure = None
        if ensure is not None:
            ensure.__enter__()
        asked = [0.0]
        while not self._stop.is_set():
            try:
                self._turn(asked)
            except Exception as e:  # never a silent stale view: unreachable, then start over
                self._close_socket()
                self._lost(f"the follower failed: {type(e).__name__}: {e}")
                self._heard = 0.0
                self._stop.wait(RETRY_S)
        self._close_socket()
        with self._lock:
            queues = list(self._queues)
        for q in queues:
            q.put(None)
        self._watch.close()
        if ensure is not None:
            ensure.__exit__(None, None, None)


Displacement = TypeVar("Displacement", float, "np.ndarray[Any, Any]")


def angle_rad(displacement_m: Displacement, zero_displacement_m: float,
              r2_m: float) -> Displacement:
    """An angle: a displacement from the zero over the radius of the sensor
    that measured it (docs/protocol.md, "Angles"). The one place it is
    computed; numpy arrays go through it too."""
    return (displacement_m - zero_displacement_m) / r2_m


def _rest_fields(rest: Optional[Mapping[str, Any]]) -> dict[str, Any]:
    """An AxisSnapshot's fields from a board's rest report."""
    if not rest:
        return {}
    return dict(noise_rad=rest.get(Key.noise_rad), age_s=rest.get(Key.age_s),
                moved_rad=float(rest.get(Key.moved_rad) or 0.0), moved=bool(rest.get(Key.moved)),
                stale=bool(rest.get(Key.stale)))
