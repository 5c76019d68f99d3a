"""One board as the Tango bridge sees it (``piezo-tango``): a client of its
``piezod`` for requests, and a thread that follows the board's stream and
keeps what the devices show -- each axis's angle, the board's state, fault
and health -- telling the devices of every change so that they push their
events. Nothing here polls a moving motor: the angles come from the
stream's sensor records as the board publishes them; ``status`` is asked
only while the stream is quiet (between runs, or when the link is down)."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import msgpack
import numpy as np
import zmq

from .board import Board, stream_address
from .errors import NoReply
from .frames import FrameError, Layout

#: How long the stream may be quiet before the board is asked (its health
#: beat comes every 250 ms).
QUIET_S = 1.0
#: How long without any answer before the board counts as unreachable.
UNREACHABLE_S = 2.0


@dataclass
class AxisView:
    """What the bridge knows of one axis."""
    name: str
    index: int
    r2_m: float
    travel_min_rad: Optional[float]
    travel_max_rad: Optional[float]
    V_max: float
    position_rad: Optional[float] = None
    zero_m: Optional[float] = None
    calibrated: bool = False
    fault: Optional[str] = None
    in_run: bool = False  #: a run of the board drives this axis now
    move: dict[str, Any] = field(default_factory=dict)


class BoardLink:
    """A board at ``address`` (CURVE ``keys`` as ``Board`` takes them).

    ``control`` is the client that moves the motor (its runs hold their
    leases); the follower thread has a client of its own, so a board that
    does not answer never holds up a stop or an e-stop behind a status
    request. Listeners are called from the follower thread with the link.
    """

    _links: dict[tuple[str, Any], "BoardLink"] = {}
    _links_lock = threading.Lock()

    @classmethod
    def of(cls, address: str, keys: Optional[tuple[str, str]] = None) -> "BoardLink":
        """The one link per board of this process (every device of the board shares it)."""
        with cls._links_lock:
            link = cls._links.get((address, keys))
            if link is None:
                link = cls._links[(address, keys)] = BoardLink(address, keys)
            return link

    def __init__(self, address: str, keys: Optional[tuple[str, str]] = None):
        self.address, self.keys = address, keys
        # Refuses a malformed address, and a network one without keys, at once.
        self.control = Board(address, keys=keys, timeout=3.0)
        self._watch = Board(address, keys=keys, timeout=1.0)
        self.hello: dict[str, Any] = {}
        #: The board start the views are of (``hello``'s ``board_id``); a new
        #: one (the board restarted) replaces everything known of the old.
        self.board_id: Optional[str] = None
        #: Counts the board starts seen: a device drops its own words of the
        #: last one (its last move's end) when this changes.
        self.generation = 0
        self.axes: dict[str, AxisView] = {}
        self.reachable = False
        self.problem = "not yet heard from"
        self.state = "unknown"
        self.fault: Optional[str] = None
        self.health: dict[str, Any] = {}
        self.last_summary: dict[str, Any] = {}
        self._listeners: list[Callable[["BoardLink"], None]] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._layout: Optional[Layout] = None
        self._thread = threading.Thread(target=self._follow, name="piezo-tango follower",
                                        daemon=True)
        self._thread.start()

    # -- for the devices ---------------------------------------------------
    def listen(self, listener: Callable[["BoardLink"], None]) -> None:
        with self._lock:
            self._listeners.append(listener)

    def forget(self, listener: Callable[["BoardLink"], None]) -> None:
        """A device that goes away; the last one's going closes the link
        (its thread ended before the server's ORB is)."""
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)
            last = not self._listeners
        if last:
            with BoardLink._links_lock:
                if BoardLink._links.get((self.address, self.keys)) is self:
                    del BoardLink._links[(self.address, self.keys)]
            # Not joined here: the thread may be pushing an event to the very
            # device whose deletion calls this. It closes its clients as it ends.
            self._stop.set()

    def wait_until_heard(self, seconds: float) -> bool:
        """Whether the board answered within ``seconds`` (a device's start)."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline and not self.reachable:
            time.sleep(0.05)
        return self.reachable

    def close(self) -> None:
        """Ends the follower, which closes both clients (a run of the
        bridge's still going is stopped: ramp to 0 V)."""
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(5)

    # -- the follower thread -------------------------------------------------
    def _tell(self) -> None:
        with self._lock:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(self)
            except Exception:  # a device's push must not end the follower
                pass

    def _lost(self, why: str) -> None:
        if self.reachable or self.problem != why:
            self.reachable, self.problem, self.state = False, why, "unknown"
            self._tell()

    def _introduce(self) -> None:
        """hello and the frame layout, once per (re)connection. A board that
        restarted is a new board: nothing known of the old start is kept
        (positions, zero, windows, the last run), and the client that moves
        the motor learns the new start before it sends anything."""
        self.hello = self._watch.hello()
        self._layout = self._watch.frame_layout
        same = self.hello.get("board_id") == self.board_id
        if not same:
            self.control.hello()
            self.board_id = self.hello.get("board_id")
            self.generation += 1
            self.last_summary, self.health = {}, {}
        views = {}
        for index, a in enumerate(self.hello.get("axes", [])):
            old = self.axes.get(a["name"]) if same else None
            views[a["name"]] = AxisView(
                name=a["name"], index=index, r2_m=float(a["r2_m"]),
                travel_min_rad=a.get("travel_min_rad"), travel_max_rad=a.get("travel_max_rad"),
                V_max=float(a["V_max"]),
                position_rad=old.position_rad if old else None)
        self.axes = views

    def _take_status(self, status: dict[str, Any]) -> None:
        self.state, self.fault = str(status["state"]), status.get("fault")
        run = status.get("run") or {}
        running = bool(run) and not run.get("finished", False)
        moving_axes = set(run.get("axes") or [])
        if run.get("summary"):
            self.last_summary = run["summary"]
        self.health = {"drive": run.get("drive") or {}, "sensor": run.get("sensor") or {}}
        for entry in status.get("axes", []):
            view = self.axes.get(entry["name"])
            if view is None:
                continue
            position = entry.get("position") or {}
            view.zero_m = position.get("zero_displacement_m")
            view.calibrated = bool(entry.get("calibrated"))
            view.fault = entry.get("fault")
            view.in_run = running and view.name in moving_axes
            if not view.in_run and position.get("position_rad") is not None:
                view.position_rad = float(position["position_rad"])
            view.move = next((m for m in run.get("moves") or [] if m["axis"] == view.name), {})

    def _ask(self) -> bool:
        try:
            if not self.hello:
                self._introduce()
            status = self._watch.status()
            if status.get("board_id") != self.board_id:  # restarted since hello
                self._introduce()
                status = self._watch.status()
            self._take_status(status)
        except NoReply as e:
            self.hello = {}
            self._lost(f"no reply from the board at {self.address}: {e}")
            return False
        except Exception as e:  # a board that answers wrongly is as good as gone
            self.hello = {}
            self._lost(f"the board at {self.address} answered wrongly: {e}")
            return False
        self.reachable, self.problem = True, ""
        self._tell()
        return True

    def _on_sensor(self, records: np.ndarray[Any, Any]) -> None:
        by_index = {v.index: v for v in self.axes.values()}
        good = records[records["status"] == 0]
        for index in np.unique(good["axis"]):
            view = by_index.get(int(index))
            if view is None or view.zero_m is None:
                continue
            latest = good[good["axis"] == index]["displacement_m"][-1]
            view.position_rad = (float(latest) - view.zero_m) / view.r2_m

    def _follow(self) -> None:
        try:
            import tango  # the devices' pushes from this thread need omniORB's blessing
            ensure: Any = tango.EnsureOmniThread()
        except (ImportError, AttributeError):
            ensure = None
        if ensure is not None:
            ensure.__enter__()
        sub: Optional[zmq.Socket[bytes]] = None
        heard = asked = 0.0
        while not self._stop.is_set():
            if sub is None:
                sub = self._watch._socket_for(zmq.SUB)
                sub.setsockopt(zmq.RCVHWM, 1000)
                sub.connect(stream_address(self.address))
                for topic in (b"sensor", b"state", b"health"):
                    sub.setsockopt(zmq.SUBSCRIBE, topic)
            now = time.monotonic()
            if now - heard > QUIET_S and now - asked > QUIET_S:
                asked = now
                if self._ask():
                    heard = now
            if not sub.poll(100):
                continue
            parts = sub.recv_multipart()
            if len(parts) != 2:
                continue
            topic, body = parts
            heard = time.monotonic()
            if topic == b"sensor" and self._layout is not None:
                try:
                    _, _, records = self._layout.decode(body)
                except FrameError:
                    continue
                self._on_sensor(records)
                self._tell()
            elif topic in (b"state", b"health"):
                event = msgpack.unpackb(body, raw=False)
                if event.get("board_id", self.board_id) != self.board_id:
                    self.hello = {}  # a new board start: introduced afresh below
                changed = (event.get("state") != self.state or "summary" in event
                           or not self.hello)
                if "summary" in event:
                    self.last_summary = event["summary"]
                if topic == b"health":
                    self.health = {k: event[k] for k in ("drive", "sensor", "move", "moves")
                                   if k in event}
                if changed:
                    asked = time.monotonic()
                    self._ask()  # the state, each axis's fault and position, at once
        if sub is not None:
            sub.close()
        self.control.close()
        self._watch.close()
        if ensure is not None:
            ensure.__exit__(None, None, None)
