"""piezo-tango as a lab's control system sees it: Tango clients
(``tango.DeviceProxy``) of the bridge's devices, served in their own
process (PyTango's MultiDeviceTestContext with process=True, or the
``piezo-tango`` program itself), against a real piezod on the simulated
rig. What the board did is read from the board (its status and the run's
summary, through an independent piezo_rig client), never only from what
the bridge says."""

import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import time

import pytest

# scripts/setup.sh installs PyTango (python3-tango): without it these tests
# fail rather than skip, so a set-up that missed it is not green.
import tango  # noqa: E402
from tango import DevState  # noqa: E402
from tango.test_context import MultiDeviceTestContext  # noqa: E402

from conftest import start_board  # noqa: E402
import peers  # noqa: E402
from piezo_rig.board import Board  # noqa: E402
from piezo_rig.tango_server import PiezoAxis, PiezoBoard  # noqa: E402

SERVER = [sys.executable, "-m", "piezo_rig.tango_server"]


def devices(address):
    return [{"class": PiezoAxis, "devices": [
                {"name": "piezo/test/rotor", "properties": {"board_address": address}}]},
            {"class": PiezoBoard, "devices": [
                {"name": "piezo/test/board", "properties": {"board_address": address}}]}]


@contextlib.contextmanager
def serving(address):
    """The bridge's devices for the board at ``address``, in a process of
    their own (a second thread-mode context in one process crashes cppTango)."""
    context = MultiDeviceTestContext(devices(address), process=True, host="127.0.0.1",
                                     port=peers.free_port(), timeout=30)
    try:
        with context:
            yield context
    finally:
        if context.thread.is_alive():  # a server that does not end on Kill
            context.thread.kill()


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """A board, and the bridge's devices for it."""
    process, address = start_board(tmp_path_factory.mktemp("tango-board"))
    with serving(address) as context:
        yield address, context
    process.terminate()
    process.wait(10)


@pytest.fixture
def axis(served):
    address, context = served
    proxy = tango.DeviceProxy(context.get_device_access("piezo/test/rotor"))
    board = tango.DeviceProxy(context.get_device_access("piezo/test/board"))
    wait_for(lambda: proxy.state() != DevState.UNKNOWN, 10, "the device hears its board")
    if board.state() == DevState.FAULT:
        board.ResetFault()
    wait_for(lambda: proxy.state() == DevState.ON, 10, "the axis idle")
    return proxy


@pytest.fixture
def board_device(served):
    return tango.DeviceProxy(served[1].get_device_access("piezo/test/board"))


@pytest.fixture
def watcher(served):
    """An independent client of the board: what the board itself says."""
    with Board(served[0]) as b:
        yield b


def wait_for(condition, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"{what}: not within {seconds} s")


def far(proxy):
    """A target a minute of steps away (from 0 on a board that has not run)."""
    return (proxy.Position or 0.0) + 0.05


def at_rest_near(position, target, tolerance):
    """A position read at rest after a move on target: the move ended within
    the tolerance by its own measurement; the board's position at rest is a
    later mean of 8 readings, which may differ by their noise (the simulated
    sensor's mean of 8 is a few µrad), so half a tolerance more."""
    return abs(position - target) <= 1.5 * tolerance


def last_summary(board):
    return (board.status().get("run") or {}).get("summary") or {}


def subscribe(proxy, name, into):
    def got(event):
        if not event.err and event.attr_value is not None:
            into.append((time.monotonic(), event.attr_value.value))
    return proxy.subscribe_event(name, tango.EventType.CHANGE_EVENT, got)


def test_a_move_is_seen_as_it_happens(axis, watcher):
    states, positions = [], []
    ids = [subscribe(axis, "State", states), subscribe(axis, "Position", positions)]
    try:
        axis.Position = 0.002
        wait_for(lambda: axis.state() == DevState.ON, 60, "the move's end")
        wait_for(lambda: states and states[-1][1] == DevState.ON, 5, "State ON pushed")
    finally:
        for i in ids:
            axis.unsubscribe_event(i)
    seen = [s for _, s in states]
    assert DevState.MOVING in seen and seen.index(DevState.MOVING) < len(seen) - 1, seen
    moving_from = next(t for t, s in states if s == DevState.MOVING)
    during = [p for t, p in positions if t >= moving_from and p is not None]
    assert len(during) >= 3, positions
    move = last_summary(watcher)["axes"][0]["move"]
    assert move["stop_cause"] == "on_target", move
    assert abs(move["position_rad"] - 0.002) <= axis.Tolerance, move
    assert at_rest_near(axis.Position, 0.002, axis.Tolerance), (axis.Position, move)


def test_stop_mid_move_ends_interrupted_at_zero_volts(axis, watcher):
    axis.Position = far(axis)  # a minute of steps
    wait_for(lambda: axis.state() == DevState.MOVING, 10, "moving")
    time.sleep(0.5)
    axis.Stop()
    wait_for(lambda: axis.state() == DevState.ON, 20, "stopped")
    summary = last_summary(watcher)
    assert summary["cause"] == "interrupted", summary
    assert summary["output"]["zero_confirmed"], summary["output"]


def test_abort_puts_zero_volts_out_without_a_ramp(axis, watcher):
    axis.Position = far(axis)
    wait_for(lambda: axis.state() == DevState.MOVING, 10, "moving")
    time.sleep(0.5)
    axis.Abort()
    wait_for(lambda: axis.state() == DevState.ON, 10, "ON: an abort latches nothing")
    summary = last_summary(watcher)
    assert summary["cause"] == "interrupted" and summary["output"]["zero_confirmed"], summary
    drive = watcher.fetch("drive", 0, summary["samples"]["drive"])
    assert drive["phase"][-1] == 2 and drive["V"][-1] == 0.0  # stopped, at 0 V
    assert not (drive["phase"] == 1).any(), "no ramp_down record: 0 V at once"


def test_define_position_zero_rezeroes(axis, watcher):
    axis.Position = 0.003
    wait_for(lambda: axis.state() == DevState.ON, 60, "arrived")
    assert abs(axis.Position - 0.003) < 1e-4
    axis.DefinePosition(0.0)
    assert abs(axis.Position) < 2e-5, axis.Position
    zero = watcher.status()["axes"][0]["position"]
    assert abs(zero["position_rad"]) < 2e-5, zero
    with pytest.raises(tango.DevFailed, match="only 0"):
        axis.DefinePosition(0.5)


def test_an_estop_from_another_client_turns_the_device_fault(axis, board_device, watcher):
    axis.Position = far(axis)
    wait_for(lambda: axis.state() == DevState.MOVING, 10, "moving")
    watcher.estop()
    wait_for(lambda: axis.state() == DevState.FAULT, 10, "FAULT")
    assert "estop" in axis.status()
    assert board_device.state() == DevState.FAULT and "estop" in board_device.status()
    board_device.ResetFault()
    wait_for(lambda: axis.state() == DevState.ON, 10, "ON")


def test_refused_writes_move_nothing(axis, watcher):
    before = (watcher.status().get("run") or {}).get("id")
    with pytest.raises(tango.DevFailed, match=r"out_of_limits \(target_rad\)"):
        axis.Position = 20.0
    with pytest.raises(tango.DevFailed, match="V0"):
        axis.Amplitude = 1e4
    with pytest.raises(tango.DevFailed, match="tolerance_rad"):
        axis.Tolerance = -1.0
    assert (watcher.status().get("run") or {}).get("id") == before
    assert axis.state() == DevState.ON
    # A write while MOVING: Tango's convention refuses it.
    axis.Position = far(axis)
    wait_for(lambda: axis.state() == DevState.MOVING, 10, "moving")
    run = watcher.status()["run"]["id"]
    with pytest.raises(tango.DevFailed, match="is moving"):
        axis.Position = 0.0
    assert watcher.status()["run"]["id"] == run
    axis.Stop()
    wait_for(lambda: axis.state() == DevState.ON, 20, "stopped")


def test_the_device_follows_its_board_going_and_coming_back(tmp_path):
    port = peers.free_port(2)
    config = tmp_path / "piezod.toml"
    with open(os.path.join(os.environ["PIEZO_SOURCE_DIR"], "configs", "piezod-sim.toml")) as f:
        config.write_text(f.read())
    address = f"tcp://127.0.0.1:{port}"

    def piezod():
        p = peers.spawn([os.environ["PIEZOD_BINARY"], "--config", str(config), "--listen",
                         address], stderr=open(tmp_path / "piezod.err", "a"))
        assert peers.wait_for_tcp(port), "piezod listens"
        return p

    board = piezod()
    with serving(address) as context:
        proxy = tango.DeviceProxy(context.get_device_access("piezo/test/rotor"))
        wait_for(lambda: proxy.state() == DevState.ON, 10, "ON")
        board.kill()
        board.wait()
        gone = time.monotonic()
        wait_for(lambda: proxy.state() == DevState.UNKNOWN, 10, "UNKNOWN")
        print(f"UNKNOWN {time.monotonic() - gone:.1f} s after piezod was killed")
        assert "unreachable" in proxy.status(), proxy.status()
        board = piezod()
        wait_for(lambda: proxy.state() == DevState.ON, 15, "ON again, the server not restarted")
        board.terminate()
        board.wait()


class BoardOnAPort:
    """piezod on a port of its own, killed and started again on it (a board
    that reboots), with `sets` (SECTION.KEY=VALUE) for each start."""

    def __init__(self, tmp_path):
        self.config = str(tmp_path / "piezod.toml")
        with open(os.path.join(os.environ["PIEZO_SOURCE_DIR"], "configs", "piezod-sim.toml")) as f:
            (tmp_path / "piezod.toml").write_text(f.read())
        self.err = str(tmp_path / "piezod.err")
        self.address = f"tcp://127.0.0.1:{peers.free_port(2)}"
        self.process = None

    def start(self, *sets):
        self.process = peers.restart_piezod(os.environ["PIEZOD_BINARY"], self.config, self.err,
                                            self.address, sets)

    def kill(self):
        self.process.kill()
        self.process.wait()

    def stop(self):
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            self.process.wait(10)


def test_a_write_the_client_gave_up_on_never_moves_the_board_that_comes_back(tmp_path):
    board = BoardOnAPort(tmp_path)
    board.start()
    try:
        with serving(board.address) as context:
            proxy = tango.DeviceProxy(context.get_device_access("piezo/test/rotor"))
            wait_for(lambda: proxy.state() == DevState.ON, 10, "ON")
            board.kill()
            # Long enough to hear the bridge give up on its board (3 s).
            proxy.set_timeout_millis(20000)
            with pytest.raises(tango.DevFailed, match="no reply"):
                proxy.Position = 0.01
            board.start()
            time.sleep(5)  # ZeroMQ's reconnection, at most 2 s apart
            with Board(board.address) as watcher:
                status = watcher.status()
                assert "run" not in status and status["state"] == "idle", status
                assert status["requests"]["move_to"] == 0, status["requests"]
    finally:
        board.stop()


def test_a_restarted_board_is_a_new_board_to_the_devices(tmp_path):
    board = BoardOnAPort(tmp_path)
    board.start("safety.travel_min_rad=-0.5", "safety.travel_max_rad=0.5")
    try:
        with serving(board.address) as context:
            proxy = tango.DeviceProxy(context.get_device_access("piezo/test/rotor"))
            proxy.set_timeout_millis(15000)
            wait_for(lambda: proxy.state() == DevState.ON, 10, "ON")
            proxy.Position = 0.003
            wait_for(lambda: proxy.state() == DevState.ON, 60, "on target")
            assert abs(proxy.Position - 0.003) < 1e-4
            assert proxy.Travel_max == 0.5
            board.kill()
            wait_for(lambda: proxy.state() == DevState.UNKNOWN, 10, "UNKNOWN")
            # Back with another window; the sensor sees the rotor from
            # further away: another zero.
            board.start("safety.travel_min_rad=-0.004", "safety.travel_max_rad=0.004",
                        "sensor.sim.target_distance_m=0.0705")
            wait_for(lambda: proxy.state() == DevState.ON, 15, "ON again")
            assert proxy.Travel_max == 0.004 and proxy.Travel_min == -0.004
            position = proxy.read_attribute("Position")
            assert position.quality == tango.AttrQuality.ATTR_INVALID, position
            assert "last move" not in proxy.status(), proxy.status()
            proxy.Position = 0.001
            wait_for(lambda: proxy.state() == DevState.ON, 60, "on target")
            with Board(board.address) as watcher:
                summary = last_summary(watcher)
                assert summary["axes"][0]["move"]["stop_cause"] == "on_target", summary
                at_rest = watcher.status()["axes"][0]["position"]["position_rad"]
            assert at_rest_near(at_rest, 0.001, 2.5e-5), at_rest
            position = proxy.read_attribute("Position")
            assert position.quality == tango.AttrQuality.ATTR_VALID
            assert abs(position.value - 0.001) < 1e-4, position.value
    finally:
        board.stop()


def start_server(tmp_path, address, *extra):
    """piezo-tango started as a supervisor starts it: output to a file, no
    variable of the caller's that changes Python's buffering. Ready when its
    board device answers a ping, as a client would find out; its readiness
    line reaches the file within seconds of that (PyTango's ORB may answer
    the ping a moment before the line is printed), where a block-buffered
    server would hold it until it exits."""
    port = peers.free_port()
    log = open(tmp_path / "tango.err", "w")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    server = peers.spawn([*SERVER, "lab", "--nodb", "--port", str(port), "--board", address,
                          *extra], stderr=log, stdout=log, env=env)
    deadline = time.monotonic() + 60
    while True:
        try:
            tango.DeviceProxy(f"tango://127.0.0.1:{port}/piezo/lab/board#dbase=no").ping()
            break
        except tango.DevFailed:
            assert server.poll() is None and time.monotonic() < deadline, \
                (tmp_path / "tango.err").read_text()
            time.sleep(0.2)
    printed = time.monotonic() + 10
    while "Ready to accept request" not in (tmp_path / "tango.err").read_text():
        assert time.monotonic() < printed, "the readiness line is written when it is printed"
        time.sleep(0.05)
    return server, port


def test_a_killed_server_leaves_the_board_to_stop_the_motor(served, watcher, tmp_path):
    address, _ = served
    if watcher.status()["state"] == "fault":
        watcher.reset_fault()
    server, port = start_server(tmp_path, address)
    try:
        proxy = tango.DeviceProxy(f"tango://127.0.0.1:{port}/piezo/lab/rotor#dbase=no")
        wait_for(lambda: proxy.state() == DevState.ON, 10, "ON")
        proxy.Position = far(proxy)
        wait_for(lambda: watcher.status()["state"] == "running", 10, "the board runs")
        server.send_signal(signal.SIGKILL)
        server.wait()
        wait_for(lambda: watcher.status()["state"] in ("idle", "fault"), 10, "the board stops")
        status = watcher.status()
        summary = status["run"]["summary"]
        assert status["fault"] == "link_lost" and summary["cause"] == "link_lost", status
        assert summary["output"]["zero_confirmed"], summary["output"]
    finally:
        server.kill()
        server.wait()
        watcher.reset_fault()


def test_a_wrong_board_address_is_refused_at_start(tmp_path):
    nobody = f"tcp://127.0.0.1:{peers.free_port(2)}"
    out = subprocess.run([*SERVER, "lab", "--nodb", "--port", str(peers.free_port()),
                          "--board", nobody], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and nobody in out.stderr and "no reply" in out.stderr, out.stderr
    out = subprocess.run([*SERVER, "lab", "--nodb", "--board", "tcp://10.1.2.3:5555"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "CURVE keys" in out.stderr, out.stderr


def listening_addresses(pid):
    """The local addresses the process ``pid`` listens on (its sockets'
    inodes in /proc/net/tcp and tcp6): its CORBA port and its events'."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        target = os.readlink(f"/proc/{pid}/fd/{fd}")
        if target.startswith("socket:["):
            inodes.add(target[len("socket:["):-1])
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as f:
            for line in f.readlines()[1:]:
                fields = line.split()
                if fields[3] == "0A" and fields[9] in inodes:  # LISTEN
                    host, port = fields[1].split(":")
                    found.append((host, int(port, 16)))
    return found


def non_loopback_address():
    """This machine's address on its default route, if it has one."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("192.0.2.1", 9))  # no packet is sent
            address = s.getsockname()[0]
    except OSError:
        return None
    return None if address.startswith("127.") else address


def test_by_default_the_server_listens_on_loopback_only(served, tmp_path):
    server, port = start_server(tmp_path, served[0])
    try:
        # Its command port, and once a client subscribes, its event ports.
        proxy = tango.DeviceProxy(f"tango://127.0.0.1:{port}/piezo/lab/rotor#dbase=no")
        proxy.subscribe_event("State", tango.EventType.CHANGE_EVENT, lambda event: None)
        listening = listening_addresses(server.pid)
        assert len(listening) >= 2 and all(host == "0100007F" for host, _ in listening), listening
        other = non_loopback_address()
        if other is not None:
            for _, p in listening:
                with socket.socket() as s:
                    assert s.connect_ex((other, p)) != 0, f"{other}:{p} accepted"
        with open(tmp_path / "tango.err") as f:
            assert re.search(r"listening on this machine only \(loopback\)", f.read())
    finally:
        server.kill()
        server.wait()


def test_every_axis_is_a_device_and_the_board_moves_a_group(tmp_path, source):
    """A board of three axes: the server makes a device of each (nothing
    else added), each moves on its own, and PiezoBoard moves a group."""
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(tmp_path / "piezod.err"), sets=["run.clock=realtime"])
    server, port = start_server(tmp_path, address)
    try:
        def device(name):
            return tango.DeviceProxy(f"tango://127.0.0.1:{port}/piezo/lab/{name}#dbase=no")

        board = device("board")
        theta, phi, chi = device("theta"), device("phi"), device("chi")
        wait_for(lambda: all(d.state() == DevState.ON for d in (theta, phi, chi)), 10, "ON")
        assert list(board.Axes) == ["theta", "phi", "chi"]
        assert chi.Travel_max == 0.5 and chi.Amplitude_max == 60.0 and phi.Amplitude_max == 80.0
        with Board(address) as b:
            assert theta.Frequency_max == b.hello()["limits"]["f_max_hz"] > 0
        with pytest.raises(tango.DevFailed, match="travel window"):
            chi.Position = 0.6
        phi.Position = -0.003
        wait_for(lambda: phi.state() == DevState.ON, 60, "phi arrived")
        assert at_rest_near(phi.Position, -0.003, phi.Tolerance)
        with Board(address) as watcher:
            assert watcher.status()["run"]["axes"] == ["phi"]
            board.MoveGroup([[0.002, 0.001], ["theta", "chi"]])
            wait_for(lambda: theta.state() == DevState.MOVING or watcher.status()["state"] != "idle",
                     10, "the group started")
            wait_for(lambda: board.state() == DevState.ON and theta.state() == DevState.ON
                     and chi.state() == DevState.ON, 60, "the group's end")
            # The devices may turn ON a poll before the board's status has
            # the group's summary.
            wait_for(lambda: [a["name"] for a in last_summary(watcher).get("axes", [])]
                     == ["theta", "chi"], 10, "the group's summary")
            ends = {a["name"]: a["move"]["stop_cause"]
                    for a in last_summary(watcher)["axes"]}
        assert ends == {"theta": "on_target", "chi": "on_target"}, ends
        assert at_rest_near(theta.Position, 0.002, theta.Tolerance)
        assert at_rest_near(chi.Position, 0.001, chi.Tolerance)
        assert board.Last_cause == "completed"
    finally:
        server.kill()
        server.wait()
        process.terminate()
        process.wait(10)


def test_the_pages_session_scans_through_the_bridge(served, watcher, tmp_path, source):
    """docs/tango.md's session, run as a reader runs it, against a bridge
    started as the page starts it."""
    if watcher.status()["state"] == "fault":
        watcher.reset_fault()
    with open(os.path.join(source, "docs", "tango.md")) as f:
        block = re.search(r"```python\n(.*?)```", f.read(), re.S).group(1)
    server, port = start_server(tmp_path, served[0])
    try:
        script = tmp_path / "session.py"
        script.write_text(block.replace("127.0.0.1:10000", f"127.0.0.1:{port}"))
        out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                             timeout=240)
        assert out.returncode == 0, out.stderr
        print(out.stdout)
        tolerance = float(re.search(r"tolerance (\S+) rad", out.stdout).group(1))
        scanned = re.findall(r"target (\S+) rad: at (\S+) rad, ON", out.stdout)
        assert len(scanned) == 4, out.stdout
        assert all(at_rest_near(float(at), float(t), tolerance) for t, at in scanned), scanned
        assert int(re.search(r"(\d+) position events", out.stdout).group(1)) >= 4
    finally:
        server.kill()
        server.wait()


def test_a_scan_through_the_bridge_pushes_a_trigger_event_per_pulse(axis, watcher):
    axis.Calibrate()
    wait_for(lambda: axis.state() == DevState.ON, 60, "the calibration's end")
    assert axis.Base_rate < axis.Velocity_max, "the calibrated range"
    with pytest.raises(tango.DevFailed) as refused:
        axis.Velocity = 2 * axis.Velocity_max
    assert "Velocity_max" in refused.value.args[0].desc
    axis.Velocity = 0.5 * (axis.Base_rate + axis.Velocity_max)
    axis.Acceleration = 0.3
    events = []
    subscription = subscribe(axis, "Trigger", events)
    try:
        start = axis.Position
        runs_before = watcher.status()["run"]["id"]
        axis.Scan([start + 0.004, start + 0.024, 0.002, 0.0005])
        wait_for(lambda: axis.state() == DevState.MOVING or
                 watcher.status()["run"]["id"] > runs_before, 10, "the scan's start")
        wait_for(lambda: axis.state() == DevState.ON, 60, "the scan's end")
        # The board's own account: every pulse it fired, each a Tango event.
        scan = last_summary(watcher)["axes"][0]["scan"]
        assert scan["stop_cause"] == "on_target", scan
        assert scan["acceleration_s"] == 0.3 and scan["triggers"]["width_s"] == 0.0005
        fired = [p["k"] for p in scan["pulses"]]
        assert fired == list(range(11))
        def pulses():  # the events of pulses (the first, at the subscription, has none)
            return [int(e[1][0]) for e in events if e[1] is not None and len(e[1]) == 5]

        wait_for(lambda: len(pulses()) >= 11, 10, "an event per pulse")
        assert pulses() == fired
        assert axis.Triggers_fired == 11
    finally:
        axis.unsubscribe_event(subscription)


def test_a_board_that_needs_keys_is_reached_with_the_bridges_own(tmp_path, source):
    """Towards the board the bridge is a client like any other: on a board
    with CURVE it brings its own keys (--keys), and without them gets no reply."""
    piezod = os.environ["PIEZOD_BINARY"]
    keys = tmp_path / "keys"
    keys.mkdir()
    for name in ("board", "bridge"):
        subprocess.run([piezod, "keygen", "--out", str(keys), "--name", name], check=True,
                       capture_output=True)
    (keys / "authorized_keys").write_text((keys / "bridge.pub").read_text())
    config = tmp_path / "curve.toml"
    with open(os.path.join(source, "configs", "piezod-sim.toml")) as f:
        config.write_text(f.read().replace(
            "[piezod]\n", f'[piezod]\nsecret_key_file = "{keys}/board.key"\n'
                          f'authorized_keys_file = "{keys}/authorized_keys"\n', 1))
    process, address = peers.start_piezod(piezod, str(config), str(tmp_path / "piezod.err"))
    try:
        refused = subprocess.run([*SERVER, "lab", "--nodb", "--port", str(peers.free_port()),
                                  "--board", address], capture_output=True, text=True,
                                 timeout=60)
        assert refused.returncode == 2 and "no reply" in refused.stderr, refused.stderr
        server, port = start_server(tmp_path, address, "--keys",
                                    f"{keys}/board.pub,{keys}/bridge.key")
        try:
            axis = tango.DeviceProxy(f"tango://127.0.0.1:{port}/piezo/lab/rotor#dbase=no")
            wait_for(lambda: axis.state() == DevState.ON, 10, "ON")
            axis.Position = 0.001
            wait_for(lambda: axis.state() == DevState.ON, 60, "arrived")
            assert at_rest_near(axis.Position, 0.001, axis.Tolerance)
        finally:
            server.kill()
            server.wait()
    finally:
        process.terminate()
        process.wait(10)


def test_the_bridge_shows_a_cut_link_and_follows_again_past_bad_messages(tmp_path):
    """The devices read the connection's follower: messages the board never
    sent are dropped (the devices stay ON, Position a number), a cut link
    is UNKNOWN with Position INVALID, and the mended link is followed again
    without restarting the server."""
    from board_link import Link
    import msgpack
    process, address = start_board(tmp_path)
    link = Link(address)
    server = None
    try:
        server, port = start_server(tmp_path, link.address)
        axis = tango.DeviceProxy(f"tango://127.0.0.1:{port}/piezo/lab/rotor#dbase=no")
        wait_for(lambda: axis.state() == DevState.ON, 10, "ON")
        wait_for(lambda: axis.read_attribute("Position").quality == tango.AttrQuality.ATTR_VALID,
                 10, "a position at rest")
        for parts in ([b"sensor", b"PZSB not a frame"], [b"health", b"\xc1"],
                      [b"state", msgpack.packb([1])], [b"gossip", b"{}"],
                      [b"health", msgpack.packb({"board_ns": 1})]):
            link.put(*parts)
        time.sleep(0.5)
        assert axis.state() == DevState.ON
        assert axis.read_attribute("Position").quality == tango.AttrQuality.ATTR_VALID
        link.down()
        wait_for(lambda: axis.state() == DevState.UNKNOWN, 15, "UNKNOWN")
        assert "unreachable" in axis.status(), axis.status()
        assert axis.read_attribute("Position").quality == tango.AttrQuality.ATTR_INVALID
        link.up()
        wait_for(lambda: axis.state() == DevState.ON, 20, "ON again, the server not restarted")
        wait_for(lambda: axis.read_attribute("Position").quality == tango.AttrQuality.ATTR_VALID,
                 10, "a number again")
    finally:
        if server is not None:
            server.kill()
            server.wait()
        link.close()
        process.terminate()
        process.wait(10)
