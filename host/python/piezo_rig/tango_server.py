"""``piezo-tango``: a board's ``piezod`` as Tango devices (PyTango's
high-level server), so a lab's control system (Tango clients, Sardana's
scans, Taurus panels) drives its motors as it drives any other.

One ``PiezoAxis`` device per axis of the board, with the names motor
interfaces use (``Position``, ``Stop``, ``Abort``, ``DefinePosition``,
``Limit_switches``, and Sardana's ``Velocity``, ``Acceleration``,
``Deceleration`` and ``Base_rate`` for a fly scan: ``Scan``, its trigger
pulses pushed as ``Trigger`` change events), and one ``PiezoBoard`` device
(e-stop, reset, health, a group move). The bridge is an ordinary client of the board
(``piezo_rig.board``): the board's limits, lease and refusals hold for it
as for any client, and a bridge that dies mid-move leaves the board to stop
the motor when the lease lapses. ``Position`` and ``State`` change events
are pushed as the board's stream brings each reading (``tango_link``).

docs/tango.md says how to start it, with a Tango database or without."""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
import threading
import time
from typing import Any, Callable, Optional

import tango
from tango import AttrQuality, AttrWriteType, DevState
from tango.server import Device, attribute, command, device_property, run

from ._wire import Command, ErrorCode, Key, MoveEnd, State
from .errors import BoardError, NoReply, RunEnded
from .tango_link import AxisView, BoardLink

#: Position change events: pushed when the angle moved by this much since
#: the last one pushed (Tango's ``abs_change``; an attribute property a
#: client may change).
POSITION_ABS_CHANGE_RAD = 1e-6


def _keys(files: list[str]) -> Optional[tuple[str, str]]:
    """The board's public key file and the bridge's secret key file, or none."""
    if not files:
        return None
    if len(files) != 2:
        raise ValueError(f"board_keys: {len(files)} files; give two: the board's public key "
                         "and this bridge's secret key")
    return files[0], files[1]


def _raise(what: str, error: BaseException) -> None:
    """The board's refusal (its code, key and message) as a Tango DevFailed."""
    reason = type(error).__name__
    if isinstance(error, BoardError):
        reason = f"{error.code}" + (f" ({error.key})" if getattr(error, Key.key, None) else "")
    tango.Except.throw_exception(reason, f"{what}: {error}", what)


def _omni_thread(work: Callable[[], None]) -> Callable[[], None]:
    """A thread's work that pushes Tango events: omniORB must know the thread."""
    def known() -> None:
        with tango.EnsureOmniThread():
            work()
    return known


class _OnBoard(Device):
    """What both devices share: the board's address and keys, its link."""

    board_address = device_property(
        dtype=str, default_value="tcp://127.0.0.1:5555",
        doc="the board's piezod command address (its stream is on port + 1)")
    board_keys = device_property(
        dtype=(str,), default_value=[],
        doc="CURVE key files (piezod keygen): the board's public key, this bridge's secret "
            "key; needed on any board address but loopback")

    link: BoardLink

    def _open_link(self) -> None:
        try:
            self.link = BoardLink.of(self.board_address, _keys(list(self.board_keys or [])))
        except (ValueError, TypeError, OSError) as e:
            _raise(f"board_address {self.board_address!r}", e)

    def _board_state(self) -> tuple[DevState, str]:
        link = self.link
        if not link.reachable:
            return DevState.UNKNOWN, f"The board at {link.address} is unreachable: {link.problem}"
        if link.state == State.fault:
            return DevState.FAULT, (f"The board latched the fault {link.fault}: ResetFault "
                                    "clears it once the cause is looked at")
        if link.state in (State.running, State.ramping_down):
            return DevState.MOVING, f"The board is {link.state.replace('_', ' ')}"
        return DevState.ON, f"The board is {link.state}"


class PiezoAxis(_OnBoard):
    """One axis (motor) of a piezo-rig board."""

    axis = device_property(dtype=str, default_value="",
                           doc="the board's axis (hello.axes); empty: its first")
    allow_retarget = device_property(
        dtype=bool, default_value=False,
        doc="a Position write while MOVING stops the move and starts one to the new target "
            "(Tango's convention, the default, refuses it)")

    def init_device(self) -> None:
        super().init_device()
        self._open_link()
        self._moving = False  # a move or calibration of this device's is under way
        self._retargeted = False  # a move waits for the stopped one to end
        self._move_error = ""
        self._generation = self.link.generation  # the board start _move_error is of
        self._last: tuple[Optional[float], Optional[DevState]] = (None, None)
        self._tolerance_rad = float("nan")
        self._f_hz = float("nan")
        self._V0 = float("nan")
        # A scan's: NaN takes the board's (velocity: the axis's highest steady one).
        self._velocity = float("nan")
        self._acceleration_s = float("nan")
        self._deceleration_s = float("nan")
        self._trigger: list[float] = []
        self._triggers_fired = 0
        self.set_change_event("Position", True, True)
        self.set_change_event("State", True, False)
        self.set_change_event("Trigger", True, False)
        if self.link.wait_until_heard(3.0):
            self._take_defaults()
        self.link.listen(self._changed)

    def delete_device(self) -> None:
        self.link.forget(self._changed)

    # -- what the board says ------------------------------------------------
    @property
    def _view(self) -> Optional[AxisView]:
        axes = self.link.axes
        if not axes:
            return None
        return axes.get(self.axis) if self.axis else next(iter(axes.values()))

    @property
    def _name(self) -> str:
        view = self._view
        return view.name if view else str(self.axis)

    def _take_defaults(self) -> None:
        """The move's defaults as the board declares them (its dictionary)."""
        try:
            args = {a[Key.name]: a for a in self.link.control.arguments(Command.move_to)}
        except (BoardError, NoReply):
            return

        def default(name: str) -> float:
            # NaN: the board picks it per move (its calibration's, say).
            value = args.get(name, {}).get(Key.default)
            return float(value) if isinstance(value, (int, float)) else float("nan")

        if self._tolerance_rad != self._tolerance_rad:
            self._tolerance_rad = default(Key.tolerance_rad)
            self._f_hz = default(Key.f)
            self._V0 = default(Key.V0)

    def _state(self) -> tuple[DevState, str]:
        state, status = self._board_state()
        view = self._view
        if state == DevState.UNKNOWN or view is None:
            return (DevState.UNKNOWN,
                    status if state == DevState.UNKNOWN else f"The board has no axis {self.axis!r}")
        moving = self._moving or self._retargeted or view.in_run
        where = ("at an unknown position" if view.position_rad is None
                 else f"at {view.position_rad:.6g} rad")
        if view.fault:
            return DevState.FAULT, (f"Axis {view.name} latched the fault {view.fault}: "
                                    "ResetFault on the board clears it")
        if state == DevState.FAULT:
            return state, status
        if moving:
            target = view.move.get(Key.target_rad)
            return DevState.MOVING, (f"Axis {view.name} is moving" +
                                     (f" to {target:.6g} rad" if target is not None else "") +
                                     f", {where}")
        ends = self._ends(view)
        if any(ends):
            return DevState.ALARM, (f"Axis {view.name} is at the {'upper' if ends[0] else 'lower'} "
                                    f"end of its travel window, {where}")
        ended = f" The last move: {self._move_error}." if self._move_error else ""
        return DevState.ON, f"Axis {view.name} is idle, {where}.{ended}"

    @staticmethod
    def _ends(view: AxisView) -> tuple[bool, bool]:
        """(upper, lower): at or past the travel window's ends."""
        p = view.position_rad
        if p is None:
            return False, False
        return (view.travel_max_rad is not None and p >= view.travel_max_rad,
                view.travel_min_rad is not None and p <= view.travel_min_rad)

    def _changed(self, link: BoardLink) -> None:
        """From the follower: pushes what changed."""
        if link.generation != self._generation:  # a new board start
            self._generation, self._move_error = link.generation, ""
        state, status = self._state()
        self.set_state(state)
        self.set_status(status)
        view = self._view
        position = view.position_rad if view else None
        if position is not None and position != self._last[0]:
            self.push_change_event("Position", position)
        if state != self._last[1]:
            self.push_change_event("State", state)
        self._last = (position, state)

    # -- Tango's own state ---------------------------------------------------
    def dev_state(self) -> DevState:
        state, status = self._state()
        self.set_state(state)
        self.set_status(status)
        return state

    def dev_status(self) -> str:
        return self._state()[1]

    # -- attributes ------------------------------------------------------------
    @attribute(dtype=float, unit="rad", format="%.7f", access=AttrWriteType.READ_WRITE,
               abs_change=str(POSITION_ABS_CHANGE_RAD),
               doc="the rotor's angle from the board's zero, as its sensor measures it; a write "
                   "moves there in closed loop (the board's move controller)")
    def Position(self) -> tuple[float, float, AttrQuality]:
        # A number whenever the board answers: between runs it reads every
        # axis at rest. INVALID only when the board (or its sensor) does not.
        view = self._view
        if (view is None or view.position_rad is None or not self.link.reachable
                or (view.stale and not view.in_run)):
            return float("nan"), 0.0, AttrQuality.ATTR_INVALID
        quality = (AttrQuality.ATTR_CHANGING if view.in_run or self._moving
                   else AttrQuality.ATTR_VALID)
        return view.position_rad, time.time(), quality

    @Position.write  # type: ignore[no-redef]
    def Position(self, target_rad: float) -> None:
        options = {Key.axis: self._name, Key.tolerance_rad: self._tolerance_rad, Key.f: self._f_hz,
                   Key.V0: self._V0}
        options = {k: v for k, v in options.items() if v == v}  # NaN: the board's default
        try:
            # Checked against the board's dictionary before anything is sent,
            # then sent: the board refuses what is beyond its limits.
            args = self.link.control.checked(Command.move_to, {Key.target_rad: target_rad, **options})
        except BoardError as e:
            _raise("Position", e)
        if self._state()[0] == DevState.MOVING:
            if not self.allow_retarget:
                tango.Except.throw_exception(
                    "moving", f"Position: axis {self._name} is moving; Stop it first (or set "
                              "the device property allow_retarget)", "Position")
            # Re-targeted: the move under way ramps down, and the new one
            # starts once it has ended, from a thread of its own (a refusal
            # then shows in Status): the write returns at once.
            self.Stop()
            self._retargeted = True
            threading.Thread(target=_omni_thread(lambda: self._move_after_the_last(args)),
                             name=f"retarget {self._name}", daemon=True).start()
            return
        self._start_move(args)

    def _start_move(self, args: dict[str, Any]) -> None:
        """The board's reply to the move comes here (a refusal is the
        writer's DevFailed); the move is followed in a thread of its own,
        so the write returns at once and other clients' reads of this
        device go on: progress comes as State and Position events."""
        from .board import Run
        self._move_error = ""
        try:
            run = Run(self.link.control, Command.move_to, args, True, raise_on_fault=False)
        except (BoardError, NoReply) as e:
            _raise("Position", e)
        self._moving = True

        @_omni_thread
        def follow() -> None:
            try:
                with run:
                    summary = run.wait()
                mine: dict[str, Any] = next(
                    (a for a in summary[Key.axes] if a[Key.name] == self._name), {})
                end = (mine.get(Key.move) or {}).get(Key.stop_cause) or mine.get(Key.cause)
                if end != MoveEnd.on_target:
                    self._move_error = f"ended {end}"
            except BaseException as e:  # noqa: B036 -- kept for Status
                self._move_error = str(e)
            finally:
                self._moving = False
                self._changed(self.link)

        threading.Thread(target=follow, name=f"move {self._name}", daemon=True).start()
        self.set_state(DevState.MOVING)
        self.push_change_event("State", DevState.MOVING)
        self._last = (self._last[0], DevState.MOVING)

    def _move_after_the_last(self, args: dict[str, Any]) -> None:
        """A re-target's move, once the stopped one has ended."""
        deadline = time.monotonic() + 10
        while self._moving and time.monotonic() < deadline:
            time.sleep(0.02)
        try:
            self._start_move(args)
        except tango.DevFailed as e:
            self._move_error = f"the re-targeted move was refused: {e.args[0].desc}"
        finally:
            self._retargeted = False
            self._changed(self.link)

    def _move_option(self, attribute: str, key: str, value: float) -> float:
        """A move's option as written, once the board's dictionary takes it
        for this axis (DevFailed naming the key and the limit otherwise)."""
        try:
            self.link.control.checked(Command.move_to, {Key.target_rad: 0.0, key: value,
                                                  Key.axis: self._name})
        except BoardError as e:
            _raise(attribute, e)
        return value

    @attribute(dtype=float, unit="rad", access=AttrWriteType.READ_WRITE, format="%.3g",
               doc="a move is on target within this (the board's default at start)")
    def Tolerance(self) -> float:
        return self._tolerance_rad

    @Tolerance.write  # type: ignore[no-redef]
    def Tolerance(self, value: float) -> None:
        self._tolerance_rad = self._move_option("Tolerance", Key.tolerance_rad, value)

    @attribute(dtype=float, unit="Hz", access=AttrWriteType.READ_WRITE,
               doc="the coarse steps' sawtooth frequency (the board's default at start)")
    def Frequency(self) -> float:
        return self._f_hz

    @Frequency.write  # type: ignore[no-redef]
    def Frequency(self, value: float) -> None:
        self._f_hz = self._move_option("Frequency", Key.f, value)

    @attribute(dtype=float, unit="V", access=AttrWriteType.READ_WRITE,
               doc="the coarse steps' amplitude V0 (the board's default at start)")
    def Amplitude(self) -> float:
        return self._V0

    @Amplitude.write  # type: ignore[no-redef]
    def Amplitude(self, value: float) -> None:
        self._V0 = self._move_option("Amplitude", Key.V0, value)

    @attribute(dtype=float, unit="V", doc="the axis's highest drive voltage, as the board declares it")
    def Amplitude_max(self) -> float:
        view = self._view
        return view.V_max if view else float("nan")

    @attribute(dtype=float, unit="Hz", doc="the highest sawtooth frequency the board takes "
                                          "(hello.limits.f_max_hz)")
    def Frequency_max(self) -> float:
        limits = self.link.hello.get(Key.limits) or {}
        return float(limits.get(Key.f_max_hz, float("nan")))

    @attribute(dtype=float, unit="rad", doc="the travel window's lower end (NaN: none)")
    def Travel_min(self) -> float:
        view = self._view
        return float("nan") if view is None or view.travel_min_rad is None else view.travel_min_rad

    @attribute(dtype=float, unit="rad", doc="the travel window's upper end (NaN: none)")
    def Travel_max(self) -> float:
        view = self._view
        return float("nan") if view is None or view.travel_max_rad is None else view.travel_max_rad

    @attribute(dtype=(bool,), max_dim_x=3,
               doc="Sardana's [home, upper, lower]: no home switch; upper and lower are the "
                   "travel window's ends (the rotor at or past them)")
    def Limit_switches(self) -> list[bool]:
        view = self._view
        upper, lower = self._ends(view) if view else (False, False)
        return [False, upper, lower]

    @attribute(dtype=bool, doc="whether the board holds a calibration for this axis")
    def Calibrated(self) -> bool:
        view = self._view
        return bool(view and view.calibrated)

    # -- commands --------------------------------------------------------------
    @command(doc_in="ramps the axis's drive to 0 V (its cause: interrupted)")
    def Stop(self) -> None:
        try:
            self.link.control.stop(self._name)
        except BoardError as e:
            if e.code not in (ErrorCode.bad_state,):  # nothing to stop
                _raise("Stop", e)
        except NoReply as e:
            _raise("Stop", e)

    @command(doc_in="0 V at once on this axis, without the ramp (the board's stop with now; "
                    "cause interrupted); a run another client controls: the board's e-stop")
    def Abort(self) -> None:
        try:
            self.link.control.stop(self._name, now=True)
        except BoardError as e:
            if e.code == ErrorCode.bad_state:
                return  # nothing runs
            if e.code != ErrorCode.not_controller:
                _raise("Abort", e)
            try:  # not this bridge's run: the one stop any client may send
                self.link.control.estop()
            except (BoardError, NoReply) as again:
                _raise("Abort", again)
        except NoReply as e:
            _raise("Abort", e)

    # -- a fly scan (Sardana's motor: velocity, acceleration and deceleration
    # times, base rate) -------------------------------------------------------
    def _axis_info(self) -> dict[str, Any]:
        """Its entry of the board's hello, asked now (a calibration changes it)."""
        try:
            info: dict[str, Any] = next(a for a in self.link.control.hello()[Key.axes]
                                        if a[Key.name] == self._name)
        except (BoardError, NoReply, StopIteration):
            return {}
        return info

    def _scan_option(self, attribute: str, key: str, value: float) -> float:
        """A scan's option as written, once the board's dictionary takes it."""
        try:
            self.link.control.checked(Command.scan, {Key.from_rad: 0.0, Key.to_rad: 1e-3,
                                                     Key.velocity_rad_per_s: 1.0, key: value,
                                                     Key.axis: self._name})
        except BoardError as e:
            _raise(attribute, e)
        return value

    @attribute(dtype=float, unit="rad/s", access=AttrWriteType.READ_WRITE, format="%.5g",
               doc="a scan's velocity over its span (NaN: the axis's highest steady velocity); "
                   "within Base_rate .. Velocity_max, from the axis's calibration")
    def Velocity(self) -> float:
        return self._velocity

    @Velocity.write  # type: ignore[no-redef]
    def Velocity(self, value: float) -> None:
        info = self._axis_info()
        low, high = info.get(Key.base_rate_rad_per_s), info.get(Key.velocity_max_rad_per_s)
        if low is None or high is None:
            tango.Except.throw_exception(
                ErrorCode.bad_state, f"Velocity: axis {self._name} is not calibrated: its velocity "
                                     "against its drive is unknown; Calibrate it first", "Velocity")
        if not low <= value <= high:
            tango.Except.throw_exception(
                ErrorCode.out_of_limits, f"Velocity: {value:g} rad/s; allowed: [{low:.4g}, "
                                         f"{high:.4g}] rad/s (Base_rate, Velocity_max)", "Velocity")
        self._velocity = value

    @attribute(dtype=float, unit="s", access=AttrWriteType.READ_WRITE,
               doc="a scan's run-up: from the base rate to Velocity in this time (NaN: the "
                   "board's default)")
    def Acceleration(self) -> float:
        return self._acceleration_s

    @Acceleration.write  # type: ignore[no-redef]
    def Acceleration(self, value: float) -> None:
        self._acceleration_s = self._scan_option("Acceleration", Key.acceleration_s, value)

    @attribute(dtype=float, unit="s", access=AttrWriteType.READ_WRITE,
               doc="a scan's run-down: from Velocity to the base rate in this time (NaN: "
                   "Acceleration's)")
    def Deceleration(self) -> float:
        return self._deceleration_s

    @Deceleration.write  # type: ignore[no-redef]
    def Deceleration(self, value: float) -> None:
        self._deceleration_s = self._scan_option("Deceleration", Key.deceleration_s, value)

    @attribute(dtype=float, unit="rad/s", format="%.5g",
               doc="the slowest steady velocity, from the axis's calibration (NaN: uncalibrated)")
    def Base_rate(self) -> float:
        value = self._axis_info().get(Key.base_rate_rad_per_s)
        return float("nan") if value is None else float(value)

    @attribute(dtype=float, unit="rad/s", format="%.5g",
               doc="the highest steady velocity, from the axis's calibration (NaN: uncalibrated)")
    def Velocity_max(self) -> float:
        value = self._axis_info().get(Key.velocity_max_rad_per_s)
        return float("nan") if value is None else float(value)

    @attribute(dtype=(float,), max_dim_x=6,
               doc="the latest trigger pulse of a scan: k, its position [rad], the measured "
                   "angle that fired it [rad], its edge [s from the run's start], late (1/0); "
                   "a change event per pulse")
    def Trigger(self) -> list[float]:
        return self._trigger

    @attribute(dtype=int, doc="trigger pulses of the current or last scan")
    def Triggers_fired(self) -> int:
        return self._triggers_fired

    @command(dtype_in=(float,),
             doc_in="a fly scan at Velocity: [from_rad, to_rad] and optionally the triggers' "
                    "[trigger_step_rad, trigger_width_s, trigger_start_rad, trigger_pulses, "
                    "trigger_pre_start_rad] (0 or NaN: none, or the board's default); returns at "
                    "once, State MOVING until it ends, a Trigger event per pulse")
    def Scan(self, argin: list[float]) -> None:
        if len(argin) < 2 or len(argin) > 7:
            tango.Except.throw_exception(
                ErrorCode.bad_argument, "Scan: [from_rad, to_rad, trigger_step_rad, "
                                        "trigger_width_s, trigger_start_rad, trigger_pulses, "
                                        "trigger_pre_start_rad]: 2 to 7 numbers", "Scan")
        if self._state()[0] == DevState.MOVING:
            tango.Except.throw_exception("moving", f"Scan: axis {self._name} is moving", "Scan")
        velocity = self._velocity
        if velocity != velocity:
            velocity = self._axis_info().get(Key.velocity_max_rad_per_s) or float("nan")
        given = list(argin) + [float("nan")] * (7 - len(argin))
        options: dict[str, Any] = {Key.axis: self._name, Key.acceleration_s: self._acceleration_s,
                                   Key.deceleration_s: self._deceleration_s,
                                   Key.trigger_step_rad: given[2] or float("nan"),
                                   Key.trigger_width_s: given[3],
                                   Key.trigger_start_rad: given[4],
                                   Key.trigger_pulses: given[5] or float("nan"),
                                   Key.trigger_pre_start_rad: given[6]}
        options = {k: v for k, v in options.items() if v == v}  # NaN: the board's default
        if Key.trigger_pulses in options:
            options[Key.trigger_pulses] = int(options[Key.trigger_pulses])
        try:
            scan = self.link.control.scan(given[0], given[1], velocity, **options)
        except (BoardError, NoReply) as e:
            _raise("Scan", e)
        self._moving = True
        self._move_error = ""
        self._triggers_fired = 0

        @_omni_thread
        def follow() -> None:
            try:
                with scan:
                    for pulse in scan.triggers():
                        self._trigger = [float(pulse.k), pulse.position_rad, pulse.angle_rad,
                                         pulse.edge_s, float(pulse.late)]
                        self._triggers_fired += 1
                        self.push_change_event("Trigger", self._trigger)
                    scan.wait()
            except BaseException as e:  # noqa: B036 -- kept for Status
                self._move_error = f"scan: {e}"
            finally:
                self._moving = False
                self._changed(self.link)

        threading.Thread(target=follow, name=f"scan {self._name}", daemon=True).start()
        self.set_state(DevState.MOVING)
        self.push_change_event("State", DevState.MOVING)
        self._last = (self._last[0], DevState.MOVING)

    @command(dtype_in=float, doc_in="the rotor's position now is this angle [rad]: the board "
                                    "keeps one zero, so only 0 is taken")
    def DefinePosition(self, value: float) -> None:
        if value != 0.0:
            tango.Except.throw_exception(
                ErrorCode.out_of_limits, f"DefinePosition: {value} rad; the board's zero is where the "
                                 "rotor is now, so only 0 is taken", "DefinePosition")
        try:
            self.link.control.zero(self._name)  # its follower reads the new frame at once
        except (BoardError, NoReply) as e:
            _raise("DefinePosition", e)
        self._changed(self.link)

    @command(doc_in="runs the board's calibration experiment for this axis (about 14 s); "
                    "State MOVING meanwhile")
    def Calibrate(self) -> None:
        if self._state()[0] == DevState.MOVING:
            tango.Except.throw_exception("moving", f"Calibrate: axis {self._name} is moving",
                                         "Calibrate")

        @_omni_thread
        def calibrate() -> None:
            try:
                self.link.control.calibrate(axis=self._name, progress=False)
                self._move_error = ""
            except (BoardError, NoReply, RunEnded) as e:
                self._move_error = f"calibration: {e}"
            finally:
                self._moving = False
                self._changed(self.link)

        self._moving = True
        threading.Thread(target=calibrate, name=f"calibrate {self._name}", daemon=True).start()


class PiezoBoard(_OnBoard):
    """The board itself: its e-stop, its faults, its loops' health, group moves."""

    def init_device(self) -> None:
        super().init_device()
        self._open_link()
        self._last_state: Optional[DevState] = None
        self.set_change_event("State", True, False)
        self.link.listen(self._changed)

    def delete_device(self) -> None:
        self.link.forget(self._changed)

    def _changed(self, link: BoardLink) -> None:
        state, status = self._board_state()
        self.set_state(state)
        self.set_status(status)
        if state != self._last_state:
            self.push_change_event("State", state)
            self._last_state = state

    def dev_state(self) -> DevState:
        state, status = self._board_state()
        self.set_state(state)
        self.set_status(status)
        return state

    def dev_status(self) -> str:
        return self._board_state()[1]

    @attribute(dtype=(str,), max_dim_x=64, doc="the board's axes, in its order")
    def Axes(self) -> list[str]:
        return list(self.link.axes)

    @attribute(dtype=int, doc="the drive loop's overruns in the current or last run")
    def Drive_overruns(self) -> int:
        return int((self.link.health.get(Key.drive) or {}).get(Key.overruns, 0))

    @attribute(dtype=int, doc="the drive loop's deadlines missed in the current or last run")
    def Drive_missed_cycles(self) -> int:
        return int((self.link.health.get(Key.drive) or {}).get(Key.missed_cycles, 0))

    @attribute(dtype=int, doc="sensor reads that failed in the current or last run")
    def Sensor_errors(self) -> int:
        return int((self.link.health.get(Key.sensor) or {}).get(Key.errors, 0))

    @attribute(dtype=str, doc="how the last run ended (its cause), empty before any")
    def Last_cause(self) -> str:
        return str(self.link.last_summary.get(Key.cause, ""))

    @command(doc_in="disables the amplifier at once, every axis (any client may)")
    def Estop(self) -> None:
        try:
            self.link.control.estop()
        except (BoardError, NoReply) as e:
            _raise("Estop", e)

    @command(doc_in="clears a latched fault, the board's and every axis's (not during a run)")
    def ResetFault(self) -> None:
        try:
            self.link.control.reset_fault()
        except (BoardError, NoReply) as e:
            _raise("ResetFault", e)

    @command(dtype_in=tango.DevVarDoubleStringArray,
             doc_in="a group move: [[targets in rad], [axis names]], every axis started on one "
                    "tick; returns once the board took it")
    def MoveGroup(self, argin: Any) -> None:
        targets, names = argin
        if len(targets) != len(names) or not names:
            tango.Except.throw_exception(
                ErrorCode.bad_argument, f"MoveGroup: {len(targets)} targets for {len(names)} axes",
                "MoveGroup")
        group = {str(n): float(t) for n, t in zip(names, targets)}
        try:
            args = self.link.control.checked(Command.move_to, {Key.targets: group})
        except BoardError as e:
            _raise("MoveGroup", e)
        # As Position's write: the board's reply here, the run followed apart.
        from .board import Run
        try:
            run = Run(self.link.control, Command.move_to, args, True, raise_on_fault=False)
        except (BoardError, NoReply) as e:
            _raise("MoveGroup", e)

        @_omni_thread
        def follow() -> None:
            try:
                with run:
                    run.wait()
            except BaseException:  # noqa: B036 -- the board's summary says how it ended
                pass

        threading.Thread(target=follow, name="group move", daemon=True).start()


def _file_database(instance: str, address: str, keys: list[str], axes: list[str]) -> str:
    """A Tango file database (``-file=``) naming one device per axis and the
    board's: what a server without a database serves."""
    server = f"piezo-tango/{instance}"
    lines = [f"{server}/DEVICE/PiezoBoard: piezo/{instance}/board",
             f"{server}/DEVICE/PiezoAxis: " + ", ".join(f"piezo/{instance}/{a}" for a in axes)]
    for device in [f"piezo/{instance}/board"] + [f"piezo/{instance}/{a}" for a in axes]:
        lines.append(f'{device}->board_address: "{address}"')
        if keys:
            lines.append(f"{device}->board_keys: " + ", ".join(f'"{k}"' for k in keys))
    for a in axes:
        lines.append(f'piezo/{instance}/{a}->axis: "{a}"')
    return "\n".join(lines) + "\n"


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="piezo-tango",
        description="A piezo-rig board as Tango devices: PiezoAxis per axis, PiezoBoard. "
                    "Listens on loopback only unless --listen says otherwise.",
        epilog="Arguments after INSTANCE that this program does not take go to Tango "
               "(-v4, ...). docs/tango.md has a worked session.")
    parser.add_argument("instance", help="the server's instance name (piezo-tango/INSTANCE)")
    parser.add_argument("--board", default="tcp://127.0.0.1:5555",
                        help="the board's piezod address (without a database; with one, the "
                             "devices' board_address property)")
    parser.add_argument("--keys", default="",
                        help="SERVER_PUBLIC,CLIENT_SECRET key files for a board on a network")
    parser.add_argument("--nodb", action="store_true",
                        help="without a Tango database: one device per axis of the board, "
                             "named piezo/INSTANCE/AXIS, and piezo/INSTANCE/board")
    parser.add_argument("--port", type=int, default=0,
                        help="the port Tango listens on (0: any; give one with --nodb, so "
                             "clients know where: tango://HOST:PORT/piezo/INSTANCE/AXIS#dbase=no)")
    parser.add_argument("--listen", default="127.0.0.1",
                        help="the address Tango listens on: 127.0.0.1 (the default) is this "
                             "machine only; 0.0.0.0 every interface, so anyone who reaches it "
                             "may move the motor (docs/tango.md, 'Listening on a network')")
    options, tango_args = parser.parse_known_args(argv)
    # Each line reaches a log file or a supervisor as it is written, whatever
    # the environment: PyTango prints its "Ready to accept request" on
    # sys.stdout, which Python block-buffers when stdout is not a terminal.
    for stream in (sys.stdout, sys.stderr):
        if isinstance(stream, io.TextIOWrapper):
            stream.reconfigure(line_buffering=True)
    keys = [k.strip() for k in options.keys.split(",")] if options.keys else []
    args = ["piezo-tango", options.instance, *tango_args]
    endpoint = f"giop:tcp:{options.listen}:{options.port or ''}"
    args += ["-ORBendPoint", endpoint]
    if options.nodb:
        # The board names its axes: ask it, and refuse a wrong address now.
        from .board import Board
        try:
            with Board(options.board, keys=_keys(keys), timeout=3.0) as board:
                axes = [a[Key.name] for a in board.hello().get(Key.axes, [])]
        except (BoardError, NoReply, ValueError, OSError) as e:
            print(f"piezo-tango: --board {options.board}: {e}", file=sys.stderr)
            return 2
        database = tempfile.NamedTemporaryFile("w", prefix="piezo-tango-", suffix=".db",
                                               delete=False)
        database.write(_file_database(options.instance, options.board, keys, axes))
        database.close()
        args += [f"-file={database.name}"]
        print(f"piezo-tango: devices piezo/{options.instance}/board and "
              + ", ".join(f"piezo/{options.instance}/{a}" for a in axes), file=sys.stderr)
    where = ("this machine only (loopback)" if options.listen.startswith("127.")
             else f"{options.listen}: anyone who reaches it may move the motor")
    print(f"piezo-tango: listening on {where}, port {options.port or 'any'}; board "
          f"{options.board}", file=sys.stderr, flush=True)
    run((PiezoAxis, PiezoBoard), args=args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
