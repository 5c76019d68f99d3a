"""A client of ``piezod``, the board's daemon, written against
docs/protocol.md (protocol 6) on python3-zmq and python3-msgpack.

>>> from piezo_rig.board import Board
>>> with Board("tcp://127.0.0.1:5555") as board:
...     with board.run(V0=60, f=10, duration=0.5) as run:
...         for block in run:              # numpy blocks, in sequence, gaps fetched
...             pass
...     move = board.move_to(0.001)        # waits for on target
>>> run.summary["cause"], len(run.sensor) == run.summary["samples"]["sensor"]
('completed', True)
>>> move["stop_cause"]
'on_target'

Every refusal raises the exception of its protocol error code
(``piezo_rig.errors``: ``OutOfLimits``, ``NotController``, ...).
"""

from __future__ import annotations

import collections
import itertools
import queue
import math
import os
import stat
import sys
import threading
import time
import tomllib
import weakref
from dataclasses import dataclass
from typing import Any, Iterator, Optional, Self, Union

import msgpack
import numpy as np
import zmq

from . import frames
from ._wire import ArgType, Command, ErrorCode, Key, MoveEnd, State, StopCause, Topic
from .follower import AxisSnapshot, Follower, angle_rad
from .trigger import Trigger
from .errors import (BadArgument, BoardError, ClientClosed, NoReply, OutOfLimits, RunEnded,
                     StaleBoard, UnknownCommand, board_error)

PROTOCOL = 6
LOOPBACK = ("tcp://127.0.0.1:", "tcp://localhost:", "tcp://[::1]:")
# Causes that are the end a caller asked for: the run ran its course, or
# this client stopped it.
EXPECTED_ENDS = (StopCause.completed, StopCause.interrupted)
#: Commands after which the follower asks the board's status at once.
_CHANGES_AN_AXIS = (Command.zero, Command.set_calibration, Command.reset_fault, Command.estop, Command.stop)


def stream_address(address: str) -> str:
    """The stream's address for a command address (docs/protocol.md,
    "Transport"): TCP port + 1; ``ipc://`` and ``inproc://`` with
    ``-stream`` appended; anything else is refused (ValueError), as
    piezo refuses it."""
    if address.startswith("tcp://"):
        host, _, port = address[len("tcp://"):].rpartition(":")
        if not host or not port.isdigit() or not 0 < int(port) < 65535:
            raise ValueError(f"address {address!r}: allowed tcp://HOST:PORT with a port in "
                             "[1, 65534] (the stream is on port + 1)")
        return f"tcp://{host}:{int(port) + 1}"
    if address.startswith(("ipc://", "inproc://")):
        return address + "-stream"
    raise ValueError(f"address {address!r}: allowed tcp://HOST:PORT, ipc://PATH, inproc://NAME")


def _seconds(name: str, value: Any) -> float:
    """A positive, finite number of seconds, or a TypeError / ValueError
    naming the argument (a timeout of -1 or NaN would make every call fail)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"Board: {name}: expected a number of seconds; got {type(value).__name__}")
    seconds = float(value)
    if not (0.0 < seconds < float("inf")):
        raise ValueError(f"Board: {name}: {seconds:g} s (allowed: (0, inf))")
    return seconds


def _wire(command: str, key: str, value: Any) -> Any:
    """An argument as msgpack carries it: numpy's scalars as the Python
    numbers they hold; a type the protocol has no value for is a TypeError
    naming the argument."""
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return [_wire(command, key, item) for item in value]
    if isinstance(value, dict):
        return {k: _wire(command, f"{key}.{k}", v) for k, v in value.items()}
    raise TypeError(f"{command}: {key}: expected a number, text or flag; "
                    f"got {type(value).__name__}")


def _check_argument(command: str, a: dict[str, Any], value: Any) -> None:
    """One argument against its description in the board's dictionary."""
    key, kind = a[Key.name], a[Key.type]
    if kind == ArgType.flag:
        if not isinstance(value, bool):
            raise BadArgument(command, key, "expected True or False", ErrorCode.bad_argument)
        return
    if kind == ArgType.map:
        if not isinstance(value, dict):
            raise BadArgument(command, key, "expected a map or None", ErrorCode.bad_argument)
        return
    if kind == ArgType.text:
        if not isinstance(value, str):
            raise BadArgument(command, key, f"expected text; got {value!r}", ErrorCode.bad_argument)
        return
    if kind == ArgType.choice:
        if value not in a[Key.choices]:
            raise BadArgument(command, key, f"{value!r}; allowed: {', '.join(a['choices'])}",
                              ErrorCode.bad_argument)
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BadArgument(command, key, f"expected a number; got {value!r}", ErrorCode.bad_argument)
    if kind == ArgType.integer and (value < 0 or value != int(value)):
        raise BadArgument(command, key, f"expected an unsigned integer; got {value!r}",
                          ErrorCode.bad_argument)
    low = -math.inf if a[Key.min] is None else a[Key.min]
    high = math.inf if a[Key.max] is None else a[Key.max]
    above = value > low if a[Key.min_open] else value >= low
    below = value < high if a[Key.max_open] else value <= high
    if not (above and below):
        unit = f" {a['unit']}" if a[Key.unit] else ""
        interval = (f"{'(' if a['min_open'] else '['}{low:g}, {high:g}"
                    f"{')' if a['max_open'] else ']'}")
        limit = f" (the board's {a['limit']} is {high:g}{unit})" if a[Key.limit] else ""
        raise OutOfLimits(command, key, f"{value:g}{unit} is beyond the board's limits; allowed: {interval}{unit}{limit}",
                          ErrorCode.out_of_limits)


def _read_key(path: str, entry: str) -> bytes:
    """A key from a ``piezod keygen`` file (TOML: ``public-key``, ``secret-key``)."""
    if entry == "secret-key" and os.stat(path).st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise PermissionError(f"{path}: readable by others; a secret key must be private: "
                              f"chmod 600 {path}")
    with open(path, "rb") as f:
        keys = tomllib.load(f)
    if entry not in keys:
        raise ValueError(f"{path}: {entry}: missing")
    return str(keys[entry]).encode()


@dataclass
class Block:
    """Consecutive samples of one stream: ``stream`` is "drive" or "sensor",
    ``first`` the first's sequence number, ``records`` a numpy structured
    array (drive: t_ns, V, phase, status, move_state; sensor: t_request_ns,
    t_response_ns, displacement_m, status)."""

    stream: str
    first: int
    records: np.ndarray[Any, Any]


class Board:
    """One connection to a board's ``piezod``.

    address: the command socket, e.g. ``tcp://127.0.0.1:5555`` (the stream is
        on port + 1).
    keys: ``(server_public_key_file, client_secret_key_file)``, the files
        ``piezod keygen`` writes, for CURVE; needed on any address but
        loopback.
    timeout: seconds to wait for each reply before raising ``NoReply``.
    stream_queue: frames the stream socket holds before ZeroMQ drops newer
        ones (a run fetches what was dropped from the board's recorder).
    silence_s: a run whose board is heard from neither on the stream (its
        health beat comes every 250 ms) nor in a reply for this long raises
        ``NoReply``: the board or the link is gone, and the board's lease
        stops the drive by itself.
    """

    def __init__(self, address: str = "tcp://127.0.0.1:5555",
                 keys: Optional[tuple[str, str]] = None, timeout: float = 3.0,
                 stream_queue: int = 1000, silence_s: float = 10.0):
        if not isinstance(address, str):
            raise TypeError(f"Board: address: expected a str such as 'tcp://127.0.0.1:5555'; "
                            f"got {type(address).__name__}")
        stream_address(address)  # an address piezo would refuse is refused here, at once
        if keys is None and not address.startswith(LOOPBACK) and address.startswith("tcp://"):
            raise ValueError(f"{address}: a network address needs CURVE keys "
                             "(keys=(server_public_key_file, client_secret_key_file))")
        self.address, self.stream_queue, self.keys = address, stream_queue, keys
        self.timeout = _seconds("timeout", timeout)
        self.silence_s = _seconds("silence_s", silence_s)
        self._context = zmq.Context()
        self._curve = None
        if keys is not None:
            server_file, client_file = keys
            self._curve = (_read_key(server_file, "public-key"),
                           _read_key(client_file, "public-key"),
                           _read_key(client_file, "secret-key"))
        # The board hands a connection under this id over to its new socket
        # (a controller stays one); random, so no other client guesses it.
        self._routing_id = b"piezo_rig-" + os.urandom(8).hex().encode()
        self._socket = self._command_socket()
        self._lock = threading.Lock()
        #: The board start this client knows (``hello()["board_id"]``); None
        #: before ``hello`` and after the board was seen to restart.
        self.board_id: Optional[str] = None
        self._ids = itertools.count(1)
        self._hello: Optional[dict[str, Any]] = None
        self._dictionary: Optional[dict[str, Any]] = None
        self._layout: Optional[frames.Layout] = None
        self._runs: "weakref.WeakSet[Run]" = weakref.WeakSet()
        #: The latest run this client started (``move_to``'s, say), with its records.
        self.last_run: Optional[Run] = None
        self._follower: Optional[Follower] = None
        self._follower_lock = threading.Lock()
        self._closed = False

    def _socket_for(self, kind: int) -> zmq.Socket[bytes]:
        s = self._context.socket(kind)
        s.setsockopt(zmq.LINGER, 0)
        if self._curve is not None:
            s.curve_serverkey, s.curve_publickey, s.curve_secretkey = self._curve
        return s

    def _command_socket(self) -> zmq.Socket[bytes]:
        s = self._socket_for(zmq.DEALER)
        s.setsockopt(zmq.ROUTING_ID, self._routing_id)
        s.connect(self.address)
        return s

    def _forget_board(self) -> None:
        """Drops what this client knew of the board: a new start is read anew."""
        self.board_id, self._hello, self._dictionary, self._layout = None, None, None, None

    def close(self) -> None:
        """Ends this client: a run of it still going is stopped (ramp to
        0 V) and its lease thread ended, then every socket is closed. Safe
        to call twice, and whatever became of the runs before."""
        if self._closed:
            return
        for run in list(self._runs):
            run.close()
        with self._follower_lock:
            follower, self._follower = self._follower, None
        if follower is not None:
            follower.close()
        self._closed = True
        self._socket.close()
        self._context.term()

    @property
    def follower(self) -> Follower:
        """This connection's one follower of the board's stream (started at
        the first use): ``follower.snapshot`` is the board and each axis as
        last heard, ``reachable`` False with the ``problem`` when it is not."""
        with self._follower_lock:
            if self._closed:
                raise ClientClosed("follower: this Board was closed")
            if self._follower is None:
                watch = Board(self.address, keys=self.keys, timeout=1.0)
                self._follower = Follower(self.address, stream_address(self.address), watch,
                                          self.stream_queue, self._forget_board)
            return self._follower

    def __enter__(self) -> "Board":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- requests -----------------------------------------------------------
    def call(self, command: str, **args: Any) -> dict[str, Any]:
        """Sends one request and returns its ``result`` map; raises the
        error code's exception (``piezo_rig.errors``) when refused, and
        ``NoReply`` after ``timeout`` seconds. Thread-safe. Every request
        that may name the board start names the one this client knows (asking
        ``hello`` first when it knows none): one the board restarted since
        raises ``StaleBoard`` and does nothing."""
        if self._hello is None and command != Command.hello and self._names_board(command):
            self.hello()
        with self._lock:
            if self._closed:
                raise ClientClosed(f"{command}: this Board was closed")
            request_id = next(self._ids)
            request = {Key.id: request_id, Key.cmd: command}
            wire_args = {key: _wire(command, key, value) for key, value in args.items()}
            if self.board_id is not None and self._names_board(command):
                wire_args[Key.board] = self.board_id
            if wire_args:
                request[Key.args] = wire_args
            self._socket.send(msgpack.packb(request))
            deadline = time.monotonic() + self.timeout
            while True:
                left = deadline - time.monotonic()
                if left <= 0 or not self._socket.poll(int(left * 1000) + 1):
                    # The request must not leave later: it goes with the
                    # socket that holds it (LINGER 0), and another is opened.
                    self._socket.close()
                    self._socket = self._command_socket()
                    raise NoReply(f"{command}: no reply from {self.address} in {self.timeout:g} s")
                reply = msgpack.unpackb(self._socket.recv(), raw=False)
                # An earlier request's late reply is dropped; a refusal with
                # no id is the board's answer to a request it could not read
                # far enough to find one (this one: one request at a time).
                if reply.get(Key.id) == request_id or reply.get(Key.id) is None:
                    break
        if not reply[Key.ok]:
            error = board_error(command, reply[Key.error])
            if isinstance(error, StaleBoard):
                self._forget_board()
            raise error
        result: dict[str, Any] = reply[Key.result]
        if command in _CHANGES_AN_AXIS and self._follower is not None:
            self._follower.refresh()  # what this client did shows in its next snapshot
        return result

    def _names_board(self, command: str) -> bool:
        """Whether ``command`` takes ``board`` on this board (its dictionary
        says; before it is read, every command but the two that never do)."""
        if self._dictionary is None:
            return command not in (Command.hello, Command.estop)
        return any(a[Key.name] == Key.board for a in
                   self._dictionary[Key.commands].get(command, {}).get(Key.args, []))

    def _axis_name(self, axis: Optional[str]) -> str:
        """``axis`` resolved once: a name of the board's (None: its one axis).
        Raises ``BadArgument`` (key ``axis``, listing the board's axes) for a
        name it lacks, or for none on a board of several."""
        hello = self._hello or self.hello()
        names = [a[Key.name] for a in hello[Key.axes]]
        if axis is None and len(names) == 1:
            return str(names[0])
        if axis in names:
            return str(axis)
        listed = ", ".join(names)
        raise BadArgument(Key.axis, Key.axis,
                          f"required: the board has several axes ({listed})" if axis is None
                          else f"{axis!r} is not an axis of the board (its axes: {listed})")

    def hello(self) -> dict[str, Any]:
        """The board: protocol, rates, limits, and each axis (``axes``: its
        name, sensor radius ``r2_m``, limits, travel window, zero and
        calibration). Raises ``BoardError`` for a protocol other than 4."""
        hello = self.call(Command.hello)
        if hello.get(Key.protocol) != PROTOCOL:
            raise BoardError(Key.hello, Key.protocol,
                             f"the board speaks protocol {hello.get('protocol')}, "
                             f"this client {PROTOCOL}")
        if self.board_id is not None and hello.get(Key.board_id) != self.board_id:
            self._forget_board()  # a new start: nothing known of the old one holds
        self._hello, self.board_id = hello, hello.get(Key.board_id)
        return hello

    def describe(self) -> dict[str, Any]:
        """The board's dictionary (docs/protocol.md, ``describe``): every
        command with its arguments (name, type, unit, range within this
        board's limits, default, doc) and the names the wire carries
        (states, stop causes, move ends, ...). Asked once per ``Board``."""
        if self._dictionary is None:
            self._dictionary = self.call(Command.describe)
        return self._dictionary

    @property
    def frame_layout(self) -> frames.Layout:
        """The sample frames' layout, as this board describes it."""
        if self._layout is None:
            self._layout = frames.Layout(self.describe()[Key.frames])
        return self._layout

    def arguments(self, command: str) -> list[dict[str, Any]]:
        """The arguments ``command`` takes on this board, as it describes them."""
        commands: dict[str, Any] = self.describe()[Key.commands]
        if command not in commands:
            raise UnknownCommand(command, Key.cmd, f"not a command of this board (its commands: "
                                 f"{', '.join(commands)})", ErrorCode.unknown_command)
        described: list[dict[str, Any]] = commands[command][Key.args]
        return described

    def checked(self, command: str, args: dict[str, Any]) -> dict[str, Any]:
        """``args`` without the ones left out (None), after the board's own
        checks, done here from its dictionary: an argument it does not take,
        or of the wrong type, raises ``BadArgument``; a value beyond its
        range ``OutOfLimits``, naming the board's limit. Nothing is sent."""
        described = {a[Key.name]: a for a in self.arguments(command)}
        given = {k: _wire(command, k, v) for k, v in args.items() if v is not None}
        for key, value in given.items():
            if key not in described:
                raise BadArgument(command, key, f"not an argument of {command} (it takes: "
                                  f"{', '.join(described) or 'none'})", ErrorCode.bad_argument)
            _check_argument(command, described[key], value)
        for name, a in described.items():
            if a[Key.required] and name not in given:
                raise BadArgument(command, name, "missing", ErrorCode.bad_argument)
        return given

    def status(self) -> dict[str, Any]:
        """The board's state now: ``state``, ``fault`` (the board's), ``run``
        (its ``axes``, a move's ``moves``, its ``summary`` once finished) and
        ``axes`` (each axis's ``position``, ``calibrated`` and ``fault``)."""
        return self.call(Command.status)

    def clock(self) -> int:
        """The board's CLOCK_MONOTONIC [ns]."""
        return int(self.call(Command.clock)[Key.board_ns])

    def zero(self, axis: Optional[str] = None) -> dict[str, Any]:
        """Makes the rotor's position now (the mean of the last 8 good
        readings) the zero; returns ``position``. Between runs only.
        ``axis``: which (required on a board of several axes)."""
        position: dict[str, Any] = self.call(Command.zero, **self.checked(Command.zero, {Key.axis: axis}))[
            Key.position]
        return position

    @property
    def axes(self) -> dict[str, "Axis"]:
        """The board's axes by name, in its order (``hello()["axes"]``):
        ``board.axes["theta"].move_to(0.01)``. A board of one has one."""
        hello = self._hello or self.hello()
        return {a[Key.name]: Axis(self, a[Key.name]) for a in hello[Key.axes]}

    def stop(self, axis: Optional[str] = None, now: bool = False) -> str:
        """Ramps the drive to 0 V and ends the run (the controller only);
        with ``axis``, that axis of the run alone (its cause
        ``interrupted``) while the others go on. ``now``: 0 V on the next
        drive deadline instead of the ramp (an abort that latches nothing)."""
        args: dict[str, Any] = {} if axis is None else {Key.axis: axis}
        if now:
            args[Key.now] = True
        return str(self.call(Command.stop, **args)[Key.state])

    def estop(self) -> str:
        """Disables the amplifier at once; any client may. Latches the fault
        ``estop`` when no run is on (``reset_fault`` clears it). Returns the
        board's state as the e-stop left it (``estop``'s ``state`` in
        docs/protocol.md)."""
        return str(self.call(Command.estop)[Key.state])

    def reset_fault(self) -> str:
        """Clears a latched fault (not during a run)."""
        return str(self.call(Command.reset_fault)[Key.state])

    def set_calibration(self, calibration: Optional[dict[str, Any]],
                        axis: Optional[str] = None) -> Optional[dict[str, Any]]:
        """Installs a calibration (a map as ``calibrate`` measures it, perhaps
        with a fitted ``model``), or clears it with None; ``axis``: whose."""
        args: dict[str, Any] = {Key.calibration: calibration}
        if axis is not None:
            args[Key.axis] = axis
        installed: Optional[dict[str, Any]] = self.call(Command.set_calibration, **args)[Key.calibration]
        return installed

    def fetch(self, stream: str, first: int, count: int) -> np.ndarray[Any, Any]:
        """Recorded samples of the current or last run from sequence number
        ``first``, up to ``count`` (fewer at the end), as a structured array.
        Raises ``NotAvailable`` for samples the recorder no longer holds."""
        out = []
        # The most one fetch returns, as the board describes `fetch`'s count.
        largest = int(next(a[Key.max] for a in self.arguments(Command.fetch) if a[Key.name] == Key.count))
        while count > 0:
            frame = self.call(Command.fetch, stream=stream, first=first,
                              count=min(count, largest))[Key.frame]
            _, _, records = self.frame_layout.decode(frame)
            out.append(records)
            if len(records) == 0:
                break
            first += len(records)
            count -= len(records)
        return np.concatenate(out) if out else np.empty(0, self.frame_layout.record(stream))

    # -- runs -----------------------------------------------------------------
    def run(self, V0: float, f: float, duration: float, *, renew: bool = True,
            **options: Any) -> "Run":
        """A sawtooth run (paper Eq. 1) of ``duration`` seconds, as a context
        manager that keeps the lease on a thread and yields ``Block`` s:

        >>> with Board("tcp://127.0.0.1:5555") as board:
        ...     with board.run(V0=60, f=10, duration=0.3) as run:
        ...         streams = {block.stream for block in run}
        >>> sorted(streams), run.summary["cause"]
        (['drive', 'sensor'], 'completed')

        ``options`` are ``configure``'s and ``start``'s other arguments as
        the board describes them (``board.arguments("configure")``:
        ``C_dr``, ``e_dr``, ``direction``; ``lease_s``), checked here
        against the board's limits before anything is sent.

        Leaving the block early stops the run (ramp to 0 V). After the loop,
        ``run.summary``, ``run.drive``, ``run.sensor`` and ``run.theta()``
        hold the whole run. A run that ends other than completed or stopped
        by this client (a fault, a lease lost) raises ``RunEnded`` at the end
        of the loop. ``renew=False`` never renews the lease: the board then
        stops by itself (``link_lost``), as it would for a dead host."""
        start_keys = {a[Key.name] for a in self.arguments(Command.start)}
        configure = {Key.V0: V0, Key.f: f, Key.duration_s: duration}
        configure.update({k: v for k, v in options.items() if k not in start_keys})
        start = {k: v for k, v in options.items() if k in start_keys}
        self.call(Command.configure, **self.checked(Command.configure, configure))
        return Run(self, Command.start, self.checked(Command.start, start), renew, axis=options.get(Key.axis))

    def step(self, count: int, V0: float, f: float, **options: Any) -> "Run":
        """Exactly ``count`` whole sawtooth periods, ending at 0 V; waits for
        the end and returns the finished ``Run`` (its ``summary``,
        samples and ``theta()``). ``options``: ``step``'s other arguments
        (``board.arguments("step")``: ``direction``, ``C_dr``, ``e_dr``,
        ``lease_s``)."""
        args = self.checked(Command.step, {Key.count: count, Key.V0: V0, Key.f: f, **options})
        with Run(self, Command.step, args, True) as run:
            run.wait()
        return run

    def move_to(self, target_rad: Union[float, dict[str, float]],
                **options: Any) -> dict[str, Any]:
        """Moves the rotor to ``target_rad`` from the board's zero in closed
        loop (the board's move controller) and waits until the move ends.

        ``target_rad`` a map of axis name to target moves several axes at
        once (a group: every axis starts on the same tick and ends on its
        own), e.g. ``board.move_to({"theta": 0.01, "phi": -0.02})``; it
        returns each axis's move by name, and raises ``RunEnded`` when any
        ended other than on target (its ``summary["axes"]`` says how each
        ended). One axis of several: ``axis="theta"``, or
        ``board.axes["theta"].move_to(0.01)``.

        Returns the move's map: ``position_rad`` (measured at 0 V),
        ``error_rad``, ``on_target_at_s``, ``steps``, ``f_hz``, ... (see
        docs/protocol.md, "Closed-loop moves").

        ``options`` are ``move_to``'s other arguments as the board describes
        them, with their defaults, units and ranges
        (``board.arguments("move_to")``): ``tolerance_rad``, ``settle_s``,
        ``timeout_s``, ``hold_s``, ``protect``, ``stall_steps``,
        ``approach`` (``"either"``, ``"forward"``: arrive from below the
        target every time, ``"reverse"``), the coarse steps' ``V0``, ``f``,
        ``C_dr``, ``e_dr``, and ``lease_s``; one left out takes the board's
        default. An unknown one raises ``BadArgument``, a value beyond the
        board's range ``OutOfLimits`` naming the board's limit, before
        anything is sent.

        Raises ``RunEnded`` (``cause``: one of the board's
        ``describe()["names"]["move_ends"]`` other than ``on_target``:
        ``stalled``, ``sensor_implausible``, ``timeout``, ``estop``,
        ``link_lost``, ...) when the move ends other than on target, and
        ``OutOfLimits`` for a tolerance below what the sensor resolves (the
        calibration's ``smallest_tolerance_rad``)."""
        if isinstance(target_rad, dict):
            return self._move_group(target_rad, options)
        args = self.checked(Command.move_to, {Key.target_rad: target_rad, **options})
        with Run(self, Command.move_to, args, True, raise_on_fault=False) as run:
            summary = run.wait()
        move: dict[str, Any] = next(
            (a.get(Key.move) or {} for a in summary[Key.axes] if a[Key.name] == run.axis), {})
        if move.get(Key.stop_cause) != MoveEnd.on_target:
            raise RunEnded(Command.move_to, str(move.get(Key.stop_cause) or summary.get(Key.cause, "?")),
                           summary)
        return move

    def _move_group(self, targets: dict[str, float], options: dict[str, Any]) -> dict[str, Any]:
        args = self.checked(Command.move_to, {Key.targets: dict(targets), **options})
        with Run(self, Command.move_to, args, True, raise_on_fault=False) as run:
            summary = run.wait()
        moves = {a[Key.name]: a.get(Key.move) or {} for a in summary[Key.axes]}
        missed = {name: m.get(Key.stop_cause) for name, m in moves.items()
                  if m.get(Key.stop_cause) != MoveEnd.on_target}
        if missed:
            raise RunEnded(Command.move_to, ", ".join(f"{k}: {v}" for k, v in missed.items()), summary)
        return moves

    def scan(self, from_rad: Optional[float] = None, to_rad: Optional[float] = None,
             velocity_rad_per_s: Optional[float] = None, *,
             scans: Optional[dict[str, dict[str, Any]]] = None, **options: Any) -> "Scan":
        """Starts a fly scan and returns it (a ``Scan``, a
        ``Run``): the axis turns from ``from_rad`` to ``to_rad`` (from its
        zero) at the mean velocity ``velocity_rad_per_s`` in closed loop on
        its measured angle, after an approach and a run-up before A, with a
        run-down after B. ``scan.triggers()`` yields each trigger pulse as
        the board fires it; ``scan.wait()`` the summary, raising
        ``RunEnded`` when an axis did not end its scan.

        ``scans`` scans several axes at once (a group), each with its own
        arguments: ``{"theta": {"from_rad": 0, "to_rad": 0.05,
        "velocity_rad_per_s": 0.02, "trigger_step_rad": 0.002}, ...}``.

        ``options``: ``scan``'s other arguments as the board describes them
        (``board.arguments("scan")``): ``axis``, ``acceleration_s``,
        ``deceleration_s``, ``trigger_step_rad`` (none: no triggers),
        ``trigger_start_rad``, ``trigger_pulses``, ``trigger_width_s``,
        ``trigger_pre_start_rad``, ``lease_s``. A velocity outside the
        axis's calibrated range (``hello()["axes"][i]["base_rate_rad_per_s"]``
        .. ``["velocity_max_rad_per_s"]``), an uncalibrated axis, or a
        trigger step under five times the sensor's peak-to-peak noise is
        refused with nothing moving."""
        args: dict[str, Any] = dict(options)
        if scans is not None:
            args[Key.scans] = {name: dict(own) for name, own in scans.items()}
        for key, value in ((Key.from_rad, from_rad), (Key.to_rad, to_rad),
                           (Key.velocity_rad_per_s, velocity_rad_per_s)):
            if value is not None:
                args[key] = value
        return Scan(self, self.checked(Command.scan, args))

    def calibrate(self, V0: Optional[float] = None, *, progress: bool = True,
                  **options: Any) -> dict[str, Any]:
        """Runs the board's calibration experiment (about 14 s at 10 Hz) and
        returns the calibration the board installed; raises ``RunEnded``
        when it measured none (``summary.calibration_error`` says why).
        ``V0`` left out is the board's; ``options``: ``calibrate``'s other
        arguments (``lease_s``). While it runs, how far it is shows on
        ``sys.stderr`` (under the running cell in a notebook) about once a
        second; ``progress=False`` keeps it quiet."""
        args = self.checked(Command.calibrate, {Key.V0: V0, **options})
        with Run(self, Command.calibrate, args, True) as run:
            shown = time.monotonic()
            began = shown
            for _ in run:
                now = time.monotonic()
                if progress and now - shown >= 1.0:
                    shown = now
                    # The board knows how far its experiment is (0..1).
                    fraction = (self.status().get(Key.run) or {}).get(Key.calibration_progress)
                    done = (f"{100 * fraction:.0f} % done after "
                            if isinstance(fraction, (int, float)) and fraction >= 0 else "")
                    print(f"calibrate: {done}{now - began:.0f} s", file=sys.stderr, flush=True)
        summary = run.summary
        calibration: Optional[dict[str, Any]] = summary.get(Key.calibration)
        if calibration is None:
            raise RunEnded(Command.calibrate, summary.get(Key.calibration_error, "no calibration"),
                           summary)
        return calibration


class Axis:
    """One axis of a board (``Board.axes``): the board's commands that act on
    one axis, with ``axis`` filled in. Its ``info`` is its entry of
    ``hello()["axes"]`` (radius, limits, travel window, backends)."""

    def __init__(self, board: Board, name: str):
        self.board, self.name = board, name

    def __repr__(self) -> str:
        return f"Axis({self.name!r})"

    @property
    def info(self) -> dict[str, Any]:
        """Its entry of ``hello()["axes"]``, asked now (its zero and
        calibration change)."""
        entry: dict[str, Any] = next(a for a in self.board.hello()[Key.axes] if a[Key.name] == self.name)
        return entry

    def status(self) -> AxisSnapshot:
        """The axis as the board's stream last said (``Board.follower``): its
        ``position_rad`` (a number whenever the board has a reading: in a run
        from its sensor records, between runs from its readings at rest),
        ``noise_rad``, ``age_s``, a move at rest (``moved``, ``moved_rad``),
        ``fault``, ``in_run`` and a move's progress. Raises ``NoReply`` with
        the reason when the board cannot be heard."""
        snapshot = self.board.follower.wait_until_heard(self.board.timeout)
        if not snapshot.reachable:
            raise NoReply(f"axis {self.name}: {snapshot.problem}")
        return snapshot.axes[self.name]

    def run(self, V0: float, f: float, duration: float, **options: Any) -> "Run":
        """``Board.run`` on this axis."""
        return self.board.run(V0, f, duration, axis=self.name, **options)

    def step(self, count: int, V0: float, f: float, **options: Any) -> "Run":
        """``Board.step`` on this axis."""
        return self.board.step(count, V0, f, axis=self.name, **options)

    def move_to(self, target_rad: float, **options: Any) -> dict[str, Any]:
        """``Board.move_to`` on this axis."""
        return self.board.move_to(target_rad, axis=self.name, **options)

    def scan(self, from_rad: float, to_rad: float, velocity_rad_per_s: float,
             **options: Any) -> "Scan":
        """``Board.scan`` on this axis."""
        return self.board.scan(from_rad, to_rad, velocity_rad_per_s, axis=self.name, **options)

    def calibrate(self, V0: Optional[float] = None, **options: Any) -> dict[str, Any]:
        """``Board.calibrate`` on this axis."""
        return self.board.calibrate(V0, axis=self.name, **options)

    def zero(self) -> dict[str, Any]:
        """``Board.zero`` on this axis."""
        return self.board.zero(self.name)

    def stop(self) -> str:
        """``Board.stop`` of this axis alone: it ramps to 0 V, the run's others go on."""
        return self.board.stop(self.name)


class Run:
    """A run this client controls (from ``Board.run``, ``step``, ...):
    iterate it for ``Block`` s in sequence, gaps fetched from the board's
    recorder (``NotAvailable`` if a gap is older than the recorder holds:
    samples lost, never silently skipped). ``started`` is the start's reply,
    ``summary`` the summary once the run ended; ``drive`` and ``sensor``
    every record so far."""

    def __init__(self, board: Board, command: str, args: dict[str, Any], renew: bool,
                 raise_on_fault: bool = True, axis: Optional[str] = None):
        self.board = board
        self.hello = board._hello or board.hello()
        # The axis it drives (a group move's first target), resolved once,
        # and the radius of the sensor that measures it.
        self.axis: str = board._axis_name(axis or args.get(Key.axis)
                                          or next(iter(args.get(Key.targets) or {}), None))
        self.r2_m = next(float(a[Key.r2_m]) for a in self.hello[Key.axes] if a[Key.name] == self.axis)
        self._raise_on_fault = raise_on_fault
        # The board's stream through this connection's follower: its
        # subscription is up before the run starts, so no record is missed.
        follower = board.follower
        follower.wait_for_stream(2.0)
        self._messages = follower.messages()
        try:
            self.started = board.call(command, **args)
        except BaseException:
            follower.drop(self._messages)
            raise
        self._heard = time.monotonic()
        self._summary: Optional[dict[str, Any]] = None  # the board's, once the run ended
        self.gaps_fetched = 0
        self._layout = board.frame_layout
        self._drive = self._layout.ids[Key.drive]
        self._sensor = self._layout.ids[Key.sensor]
        self._next = {stream: 0 for stream in self._layout.names}
        self._blocks: dict[int, list[np.ndarray[Any, Any]]] = {s: [] for s in self._layout.names}
        self._pending: list[Block] = []
        self._stopping = threading.Event()
        self._closed = False
        self._lease = threading.Thread(target=self._renew, args=(renew,), daemon=True)
        self._lease.start()
        board._runs.add(self)
        board.last_run = self

    def _renew(self, renew: bool) -> None:
        period = float(self.started[Key.lease_s]) / 4
        while renew and not self._stopping.wait(period):
            try:
                self.board.call(Command.lease, drive_received=self._next[self._drive])
            except (BoardError, ClientClosed):
                return  # the run has ended (bad_state / not_controller), or the client
            except NoReply:
                continue  # the link is down; the board's lease decides

    def close(self) -> None:
        """Stops the run if it is still going (ramp to 0 V, cause
        ``interrupted``), ends the lease thread and closes the stream
        socket. ``with`` does this; ``Board.close`` too, for a run used
        without ``with``. Safe to call twice."""
        if self._closed:
            return
        try:
            if self._summary is None:
                try:
                    self.board.stop()
                except (BoardError, NoReply, ClientClosed):
                    pass  # it ended meanwhile, or the board is gone: its lease stops it
        finally:
            self._closed = True
            self._stopping.set()
            if self._lease is not threading.current_thread():
                self._lease.join()
            if self.board._follower is not None:
                self.board._follower.drop(self._messages)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        try:
            if self._summary is None and not self._closed:
                try:
                    try:
                        self.board.stop()
                    except BoardError:
                        pass  # it ended meanwhile
                    self._drain(raise_on_fault=False)
                except Exception:
                    if exc_type is None:
                        raise
                    # else the exception that left the block (a KeyboardInterrupt,
                    # say) says more; the stop was sent, the board's lease does the rest
        finally:
            self.close()

    def __iter__(self) -> Iterator[Block]:
        if self._closed and self._summary is None:
            raise ClientClosed("this run was closed before its end")
        while self._summary is None or self._pending:
            if self._pending:
                yield self._pending.pop(0)
                continue
            self._receive(0.5)
        assert self._summary is not None
        if self._raise_on_fault and self._summary[Key.cause] not in EXPECTED_ENDS:
            raise RunEnded(Key.run, self._summary[Key.cause], self._summary)

    def wait(self) -> dict[str, Any]:
        """Receives the run to its end and returns its summary."""
        for _ in self:
            pass
        assert self._summary is not None
        return self._summary

    def _drain(self, raise_on_fault: bool) -> None:
        keep, self._raise_on_fault = self._raise_on_fault, raise_on_fault
        try:
            self.wait()
        finally:
            self._raise_on_fault = keep

    def _receive(self, seconds: float) -> None:
        try:
            message = self._messages.get(timeout=seconds)
        except queue.Empty:
            message = ()
        if message is None or self._closed or self.board._closed:
            # Board.close() from another thread (a notebook's stop button)
            # ended the follower under this loop: the run was stopped there.
            raise ClientClosed("this run's Board was closed while the run was being "
                               "received; the run was stopped")
        if not message:
            self._check_alive()
            return
        self._heard = time.monotonic()
        topic, body = message
        if topic not in (Topic.drive, Topic.sensor, Topic.state):
            self._on_other(topic, body)
            return
        if topic == Topic.state:
            event = msgpack.unpackb(body, raw=False)
            if Key.summary in event and event.get(Key.state) in (State.idle, State.fault):
                self._finish(event[Key.summary])
            return
        stream, first, records = self._layout.decode(body)
        if first > self._next[stream]:
            self._fetch_gap(stream, first)
        if first + len(records) > self._next[stream]:
            self._accept(stream, records[self._next[stream] - first:])

    def _on_other(self, topic: str, body: bytes) -> None:
        """A message of another topic (a scan takes its triggers)."""

    def _check_alive(self) -> None:
        # Nothing heard: a state event sent while the link was down is not
        # repeated, but status reports the finished run.
        try:
            status = self.board.status()
        except NoReply:
            # The link is down; ZeroMQ reconnects, the board's lease decides.
            silent = time.monotonic() - self._heard
            if silent > self.board.silence_s:
                raise NoReply(f"the board at {self.board.address} has been silent for "
                              f"{silent:.0f} s; its lease stops the drive") from None
            return
        self._heard = time.monotonic()

        run = status.get(Key.run) or {}
        if run.get(Key.id) == self.started.get(Key.run) and run.get(Key.summary) is not None:
            self._finish(run[Key.summary])

    def _fetch_gap(self, stream: int, until: int) -> None:
        name = self._layout.names[stream]
        missing = until - self._next[stream]
        self._accept(stream, self.board.fetch(name, self._next[stream], missing))
        self.gaps_fetched += missing

    def _accept(self, stream: int, records: np.ndarray[Any, Any]) -> None:
        if len(records) == 0:
            return
        block = Block(self._layout.names[stream], self._next[stream], records)
        self._next[stream] += len(records)
        self._blocks[stream].append(records)
        self._pending.append(block)

    def _finish(self, summary: dict[str, Any]) -> None:
        # The tail the stream had not delivered yet is in the recorder.
        for stream, name in self._layout.names.items():
            total = summary.get(Key.samples, {}).get(name, self._next[stream])
            if total > self._next[stream]:
                self._fetch_gap(stream, total)
        self._summary = summary
        if self.board._follower is not None:
            self.board._follower.refresh()  # the run's end: its axes' positions, faults

    @property
    def summary(self) -> dict[str, Any]:
        """The board's summary of the run once it ended (``cause``,
        ``samples``, each loop's health, a move's ``move``); empty before."""
        return self._summary or {}

    @property
    def drive(self) -> np.ndarray[Any, Any]:
        """Every drive record so far (t_ns, V, phase, status, move_state)."""
        return _joined(self._blocks[self._drive], self._layout.records[self._drive])

    @property
    def sensor(self) -> np.ndarray[Any, Any]:
        """Every sensor record so far (t_request_ns, t_response_ns,
        displacement_m, status)."""
        return _joined(self._blocks[self._sensor], self._layout.records[self._sensor])

    @property
    def axes(self) -> list[str]:
        """The axes this run drives, in the board's order: one, or a group
        move's each (``theta(axis=...)``, ``fit_arrays(axis=...)`` take any)."""
        moves = self.started.get(Key.moves) or self.started.get(Key.scans)
        return [str(m[Key.axis]) for m in moves] if moves else [self.axis]

    @property
    def zero_displacement_m(self) -> Optional[float]:
        """The angles' zero: the move's (its reply carries it), else the
        run's first good reading (docs/protocol.md, "Angles"); a group
        move's first axis's (``zero_of(axis)`` for another)."""
        return self.zero_of(self.axis)

    def zero_of(self, axis: Optional[str]) -> Optional[float]:
        """The zero of ``axis``'s angles in this run (None: the run's axis)."""
        axis = axis or self.axis
        moves = self.started.get(Key.moves) or self.started.get(Key.scans) or []
        started: dict[str, Any] = next((m for m in moves if m[Key.axis] == axis), {})
        if started.get(Key.zero_displacement_m) is not None:
            return float(started[Key.zero_displacement_m])
        sensor = self.records_of(axis, self.sensor)
        good = sensor[sensor[Key.status] == 0]
        return float(good[Key.displacement_m][0]) if len(good) else None

    def records_of(self, axis: Optional[str],
                   records: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
        """The records of ``axis`` among ``records`` (a group move's
        records carry their axis; None: the run's axis)."""
        names = [a[Key.name] for a in self.hello[Key.axes]]
        axis = axis or self.axis
        if axis not in names:
            raise ValueError(f"axis {axis!r}: not an axis of this board (its axes: "
                             f"{', '.join(names)})")
        index = names.index(axis)
        mine: np.ndarray[Any, Any] = records[records[Key.axis] == index]
        return mine

    def t(self, records: Optional[np.ndarray[Any, Any]] = None) -> np.ndarray[Any, Any]:
        """Times [s] from the run's origin ``t0_ns`` of drive or sensor
        records (sensor: the request's time)."""
        records = self.sensor if records is None else records
        field = Key.t_ns if Key.t_ns in records.dtype.names else Key.t_request_ns
        seconds: np.ndarray[Any, Any] = (records[field] - self.started[Key.t0_ns]) * 1e-9
        return seconds

    def theta(self, records: Optional[np.ndarray[Any, Any]] = None,
              axis: Optional[str] = None) -> np.ndarray[Any, Any]:
        """Angles [rad] of sensor records (all of the run's axis's by
        default; ``axis`` names another of a group move): the displacement
        from that axis's zero over the radius of the sensor that measured it;
        NaN where the reading failed."""
        axis = axis or self.axis
        records = self.records_of(axis, self.sensor if records is None else records)
        r2_m = next(float(a[Key.r2_m]) for a in self.hello[Key.axes] if a[Key.name] == axis)
        zero = self.zero_of(axis)
        theta = angle_rad(records[Key.displacement_m], zero or 0.0, r2_m)
        return np.where(records[Key.status] == 0, theta, np.nan)

    def fit_arrays(self, axis: Optional[str] = None) -> tuple[
            np.ndarray[Any, Any], np.ndarray[Any, Any], np.ndarray[Any, Any], np.ndarray[Any, Any]]:
        """(drive_t, drive_V, t, theta) of ``axis`` in this run (None: the
        run's axis; any axis of a group move) for ``piezo_rig.model.identify``,
        as ``piezo run`` logs them: the drive's times shifted by the board's
        output latency (``hello``'s ``output_latency_s``: the amplifier
        follows a command that much later), the failed readings (NaN angle)
        left out. An axis the board lacks raises ValueError naming its axes."""
        drive = self.records_of(axis, self.drive)
        sensor = self.records_of(axis, self.sensor)
        drive_t = self.t(drive) + float(self.hello.get(Key.output_latency_s, 0.0))
        t, theta = self.t(sensor), self.theta(sensor, axis)
        good = ~np.isnan(theta)
        return drive_t, drive[Key.V].astype(float), t[good], theta[good]


class Scan(Run):
    """A fly scan this client controls (``Board.scan``): a ``Run`` whose
    trigger pulses come as the board fires them (``triggers()``), its
    samples beside as any run's; ``pulses(axis)`` every pulse of an axis
    from the board's summary once it ended (complete even where the stream
    lost some), ``accounts`` each axis's scan by name::

        with board.scan(0.01, 0.06, 0.03, axis="theta", trigger_step_rad=0.002) as scan:
            for pulse in scan.triggers():      # each as the board fires it
                print(pulse.axis, pulse.k, pulse.angle_rad)
    """

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


def _joined(blocks: list[Any], dtype: np.dtype[Any]) -> np.ndarray[Any, Any]:
    return np.concatenate(blocks) if blocks else np.empty(0, dtype)
