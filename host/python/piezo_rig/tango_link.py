"""One board as the Tango bridge sees it (``piezo-tango``): a client of its
``piezod`` for requests (``control``) and that client's follower of the
board's stream (``piezo_rig.follower``), whose snapshots the devices read
and whose changes make them push their events. Nothing here polls a moving
motor: the angles come from the stream as the board publishes them."""

from __future__ import annotations

import threading
from typing import Any, Callable, Mapping, Optional

from .board import Board
from .follower import AxisSnapshot, BoardSnapshot

#: What the devices know of one axis: the follower's immutable snapshot.
AxisView = AxisSnapshot


class BoardLink:
    """A board at ``address`` (CURVE ``keys`` as ``Board`` takes them).

    ``control`` is the client that moves the motor (its runs hold their
    leases); its follower has a client of its own, so a board that does not
    answer never holds up a stop or an e-stop behind a status request.
    Listeners are called from the follower's thread with the link.
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
        self.follower = self.control.follower
        self._listeners: list[Callable[["BoardLink"], None]] = []
        self._lock = threading.Lock()
        self.follower.listen(self._tell)

    # -- what the board says (the follower's latest snapshot) ----------------
    @property
    def snapshot(self) -> BoardSnapshot:
        return self.follower.snapshot

    @property
    def reachable(self) -> bool:
        return self.snapshot.reachable

    @property
    def problem(self) -> str:
        return self.snapshot.problem

    @property
    def state(self) -> str:
        return self.snapshot.state

    @property
    def fault(self) -> Optional[str]:
        return self.snapshot.fault

    @property
    def health(self) -> Mapping[str, Any]:
        return self.snapshot.health

    @property
    def last_summary(self) -> Mapping[str, Any]:
        return self.snapshot.last_summary

    @property
    def axes(self) -> Mapping[str, AxisSnapshot]:
        return self.snapshot.axes

    @property
    def generation(self) -> int:
        """Counts the board starts seen: a device drops its own words of the
        last one (its last move's end) when this changes."""
        return self.snapshot.generation

    @property
    def hello(self) -> dict[str, Any]:
        return self.follower.hello

    # -- for the devices ---------------------------------------------------
    def listen(self, listener: Callable[["BoardLink"], None]) -> None:
        with self._lock:
            self._listeners.append(listener)

    def forget(self, listener: Callable[["BoardLink"], None]) -> None:
        """A device that goes away; the last one's going closes the link."""
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)
            last = not self._listeners
        if last:
            with BoardLink._links_lock:
                if BoardLink._links.get((self.address, self.keys)) is self:
                    del BoardLink._links[(self.address, self.keys)]
            # Not here: the follower may be pushing an event to the very
            # device whose deletion calls this. A thread of its own closes it.
            threading.Thread(target=self.close, daemon=True).start()

    def wait_until_heard(self, seconds: float) -> bool:
        """Whether the board answered within ``seconds`` (a device's start)."""
        return self.follower.wait_until_heard(seconds).reachable

    def close(self) -> None:
        """Ends the follower and the client (a run of the bridge's still
        going is stopped: ramp to 0 V)."""
        self.control.close()

    def _tell(self, _: BoardSnapshot) -> None:
        with self._lock:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(self)
            except Exception:  # a device's push must not end the follower
                pass

