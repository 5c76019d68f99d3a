"""One shape for any number of axes: every protocol command and every CLI
command on a board of one axis (configs/piezod-sim.toml) and on a board of
three (configs/three-axes.toml), through a real piezod, as a client sees
them. The replies carry their axes the same way on both; `axis` may be left
out on the board of one only; an axis the board lacks is refused
everywhere, listing the board's axes."""

import os
import subprocess
import time
from types import SimpleNamespace

import h5py
import pytest

import peers
from piezo_rig import errors
from piezo_rig.board import Board

# The board's config, the axis the commands name (None: left out), its axes.
BOARDS = {"one": ("piezod-sim.toml", None, ["rotor"]),
          "three": ("three-axes.toml", "chi", ["theta", "phi", "chi"])}
AXIS_COMMANDS = ("configure", "step", "move_to", "scan", "calibrate", "set_calibration", "zero")


@pytest.fixture(scope="module", params=sorted(BOARDS))
def rig(request, tmp_path_factory, source):
    config, axis, names = BOARDS[request.param]
    where = tmp_path_factory.mktemp(request.param)
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", config),
        str(where / "piezod.err"),
        sets=["run.clock=virtual", f"piezod.calibration_file={where / 'calibration.json'}"])
    yield SimpleNamespace(address=address, axis=axis, names=names, where=where,
                          name=axis or names[0],
                          config=os.path.join(source, "configs", config))
    process.terminate()
    process.wait(10)


def named(rig, **args):
    """`args` with the rig's axis, when it names one."""
    return {**args, "axis": rig.axis} if rig.axis else args


def ended(board, run_id, timeout=60):
    """The summary of run `run_id`, once the board says it ended; its lease
    renewed meanwhile, as a controller does (every sample taken)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        run = board.call("status").get("run") or {}
        if run.get("id") == run_id and run.get("finished"):
            return run["summary"]
        try:
            board.call("lease", drive_received=2**62)
        except errors.BoardError:
            pass  # ended between the two requests
        time.sleep(0.05)
    raise AssertionError(f"run {run_id} did not end")


def test_every_protocol_command(rig):
    with Board(rig.address) as board:
        hello = board.call("hello")
        assert hello["protocol"] == 6
        assert [a["name"] for a in hello["axes"]] == rig.names
        assert not {"sensor", "calibration"} & set(hello), "nothing of an axis at the top"
        described = board.call("describe")["commands"]
        for command in AXIS_COMMANDS:
            axis = next(a for a in described[command]["args"] if a["name"] == "axis")
            assert axis["choices"] == rig.names, command
            # move_to and scan may name their axes in `targets` or `scans`
            # instead (a group).
            assert axis["required"] == (len(rig.names) > 1 and
                                        command not in ("move_to", "scan")), command
        status = board.call("status")
        assert [a["name"] for a in status["axes"]] == rig.names
        assert not {"position", "calibration"} & set(status)
        assert board.call("clock")["board_ns"] >= 0  # the virtual clock starts at 0

        # configure + start, lease, stop: a run of the axis named.
        board.call("configure", **named(rig, V0=40.0, f=10.0, duration_s=5.0))
        started = board.call("start")
        run = board.call("status")["run"]
        assert run["axes"] == [rig.name] and "moves" not in run and "axis" not in run
        assert board.call("lease")["lease_s"] > 0
        board.call("stop")
        summary = ended(board, started["run"])
        assert [a["name"] for a in summary["axes"]] == [rig.name] and "move" not in summary

        stepped = board.call("step", **named(rig, count=2, V0=40.0, f=10.0))
        summary = ended(board, stepped["run"])
        assert summary["cause"] == "completed" and summary["axes"][0]["name"] == rig.name

        board.call("zero", **named(rig))
        moved = board.call("move_to", **named(rig, target_rad=0.001, tolerance_rad=5e-5))
        assert [m["axis"] for m in moved["moves"]] == [rig.name] and "move" not in moved
        summary = ended(board, moved["run"])
        assert summary["axes"][0]["move"]["stop_cause"] == "on_target", summary
        frame = board.call("fetch", stream="drive", first=0, count=10)["frame"]
        assert isinstance(frame, bytes) and len(frame) > 24

        calibrating = board.call("calibrate", **named(rig))
        summary = ended(board, calibrating["run"], timeout=180)
        assert summary["calibration"] is not None, summary.get("calibration_error")
        entry = next(a for a in board.call("hello")["axes"] if a["name"] == rig.name)
        assert entry["calibration"]["created"] == summary["calibration"]["created"]
        # A scan of the axis, now calibrated: its velocities from the calibration.
        v = 0.5 * (entry["base_rate_rad_per_s"] + entry["velocity_max_rad_per_s"])
        scanning = board.call("scan", **named(rig, from_rad=0.0, to_rad=0.01, velocity_rad_per_s=v,
                                              trigger_step_rad=0.002))
        assert [s["axis"] for s in scanning["scans"]] == [rig.name]
        summary = ended(board, scanning["run"])
        scanned = summary["axes"][0]["scan"]
        assert scanned["stop_cause"] == "on_target" and len(scanned["pulses"]) == 6, scanned
        assert board.call("set_calibration", **named(rig, calibration=None))["calibration"] is None

        assert board.call("estop")["state"] == "fault"
        assert board.call("status")["fault"] == "estop"
        assert board.call("reset_fault")["state"] == "idle"

        # An axis the board lacks, on every command that takes one (its
        # other arguments given).
        others = {"configure": dict(V0=40.0, f=10.0, duration_s=1.0),
                  "step": dict(count=1, V0=40.0, f=10.0), "move_to": dict(target_rad=0.001),
                  "scan": dict(from_rad=0.0, to_rad=0.01, velocity_rad_per_s=0.01),
                  "calibrate": {}, "set_calibration": dict(calibration=None), "zero": {}}
        for command in AXIS_COMMANDS:
            with pytest.raises(errors.BadArgument, match=", ".join(rig.names)):
                board.call(command, axis="nope", **others[command])


def piezo(*args):
    return subprocess.run([os.environ["PIEZO_BINARY"], *args], capture_output=True, text=True,
                          timeout=300)


def test_every_cli_command(rig):
    axis = ["--axis", rig.axis] if rig.axis else []
    rig_args = ["--rig", rig.address]
    out = rig.where / "cli"

    def ok(*args):
        r = piezo(*args)
        assert r.returncode == 0, (args, r.stderr)
        return r.stdout

    assert rig.names[-1] in ok("hello", *rig_args)
    assert all(f"axis {n}" in ok("status", *rig_args) for n in rig.names)
    ok("run", "--config", rig.config, *rig_args, *axis, "--duration", "0.5", "--json",
       "--out", str(out / "run"))
    ok("zero", *rig_args, *axis)
    ok("step", "2", *rig_args, *axis, "--V0", "40", "--json", "--out", str(out / "step"))
    ok("move", "--to", "0.0005", *rig_args, *axis, "--json", "--out", str(out / "move"))
    ok("calibrate", *rig_args, *axis, "--json", "--out", str(out / "calibrate"))
    ok("scan", "--from", "0", "--to", "0.01", "--velocity", "0.02", "--trigger-step", "0.002",
       *rig_args, *axis, "--json", "--out", str(out / "scan"))
    for run in ("run", "step", "move", "scan"):
        with h5py.File(out / run / "run.h5") as f:
            assert f.attrs["axes"].decode() == rig.name, run
            assert len(f[f"axes/{rig.name}/drive/V"]) > 0, run
    log = str(out / "run" / "run.h5")
    ok("report", str(out / "run"), *axis, "--json", "--out", str(out / "report"))
    ok("identify", "--log", log, *axis, "--params", "F_N", "--max-iterations", "3", "--json")
    ok("compare", "--log", log, *axis, "--json")
    ok("recover", str(out / "run"), "--json")
    ok("estop", *rig_args)
    ok("reset-fault", *rig_args)
    # The sensor of the config's axis, read on this machine (no board).
    read = ok("sensor", "read", "--config", rig.config, *axis, "--count", "3", "--json")
    assert '"displacement_m"' in read, read
    # An axis the board (or the log) lacks, refused naming what there is.
    for args in (["step", "1", *rig_args], ["move", "--to", "0.001", *rig_args],
                 ["zero", *rig_args], ["identify", "--log", log, "--params", "F_N"],
                 ["sensor", "read", "--config", rig.config, "--count", "1"]):
        r = piezo(*args, "--axis", "nope")
        assert r.returncode != 0, (args, r.stderr)
        assert "nope" in r.stderr and rig.name in r.stderr, (args, r.stderr)


@pytest.mark.parametrize("shape", sorted(BOARDS))
def test_an_axis_fault_latches_on_its_axis_on_a_board_of_one_as_of_three(shape, tmp_path,
                                                                         source):
    """One latch rule whatever the count: a sensor that stops answering
    ends its axis's run `sensor_fault`, latched on that axis (the board goes
    back to idle); a run on it is refused until reset_fault. The board's own
    causes (the e-stop, test_every_protocol_command) latch on the board."""
    config, axis, names = BOARDS[shape]
    name = axis or names[0]
    stall = (f"axes.{axis}.sensor.sim.stall_at_s=0.5" if axis
             else "sensor.sim.stall_at_s=0.5")
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", config),
        str(tmp_path / "piezod.err"), sets=["run.clock=virtual", stall])
    try:
        with Board(address) as board:
            with pytest.raises(errors.RunEnded, match="sensor_fault"):
                board.axes[name].step(30, 40, 10).wait()
            status = board.status()
            assert status["state"] == "idle" and status["fault"] is None, status
            faults = {a["name"]: a["fault"] for a in status["axes"]}
            assert faults == {n: ("sensor_fault" if n == name else None) for n in names}
            with pytest.raises(errors.FaultLatched, match=f"axis {name}"):
                board.axes[name].step(1, 40, 10)
            assert board.reset_fault() == "idle"
            assert all(a["fault"] is None for a in board.status()["axes"])
    finally:
        process.terminate()
        process.wait(10)
