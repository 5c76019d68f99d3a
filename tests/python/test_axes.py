"""A board of three axes (configs/three-axes.toml) through piezo_rig.board
and a real piezod: the board lists its axes with their own geometry and
limits, each axis runs and moves on its own with its own zero, and a
request that names no axis, or one the board lacks, is refused before
anything moves."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import peers
from piezo_rig import errors
from piezo_rig.board import Board, Run


@pytest.fixture(scope="module")
def board_address(tmp_path_factory, source):
    where = tmp_path_factory.mktemp("axes")
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(where / "piezod.err"), sets=[f"piezod.calibration_file={where / 'calibration.json'}"])
    yield address
    process.terminate()
    process.wait(10)


def test_hello_lists_every_axis_with_its_geometry_and_limits(board):
    axes = board.hello()["axes"]
    assert [a["name"] for a in axes] == ["theta", "phi", "chi"]
    assert list(board.axes) == ["theta", "phi", "chi"]
    assert axes[1]["r2_m"] == 0.08 and axes[0]["r2_m"] == 0.062
    assert axes[2]["V_max"] == 60.0 and axes[0]["V_max"] == 80.0
    assert axes[2]["travel_min_rad"] == -0.5 and axes[2]["travel_max_rad"] == 0.5
    assert axes[0]["travel_max_rad"] is None
    described = {a["name"]: a for a in board.arguments("step")}
    assert described["axis"]["choices"] == ["theta", "phi", "chi"]
    assert described["axis"]["required"]


def test_a_request_naming_no_axis_or_one_the_board_lacks_is_refused(board):
    with pytest.raises(errors.BadArgument) as refused:
        board.call("step", count=1, V0=40, f=10)
    assert "theta, phi, chi" in str(refused.value)
    with pytest.raises(errors.BadArgument) as refused:
        board.call("step", count=1, V0=40, f=10, axis="psi")
    assert "psi" in str(refused.value) and "theta, phi, chi" in str(refused.value)
    with pytest.raises(errors.BadArgument):
        board.axes["theta"].board.step(1, 40, 10, axis="psi")  # the client's own check
    with pytest.raises(errors.OutOfLimits) as refused:
        board.axes["chi"].step(1, 70, 10)  # chi's own V_max is 60 V
    assert "V0" in str(refused.value)
    assert board.status()["state"] == "idle" and "run" not in board.status()


def test_each_axis_steps_with_its_own_sensor_and_zero(board):
    phi = board.axes["phi"].step(5, 60, 10)
    assert phi.summary["cause"] == "completed"
    assert phi.axis == "phi" and phi.axes == ["phi"] and phi.r2_m == 0.08
    assert board.status()["run"]["axes"] == ["phi"]
    theta_phi = phi.theta()
    assert np.nanmax(theta_phi) > 1e-3  # 60 V, 10 Hz, five periods: forward
    positions = {a["name"]: a for a in board.status()["axes"]}
    # phi's position is its own sensor's over its own radius, from its zero:
    # the mean of its last 8 good readings, as for a board of one.
    good = theta_phi[~np.isnan(theta_phi)]
    assert positions["phi"]["position"]["position_rad"] == pytest.approx(np.mean(good[-8:]),
                                                                          abs=1e-9)
    # theta and chi have not run: no readings, no position (the simulated
    # rig's virtual clock reads nothing at rest: docs/protocol.md, "At rest").
    assert positions["theta"]["position"]["position_rad"] is None
    assert positions["chi"]["position"]["zero_displacement_m"] is None

    chi = board.axes["chi"].step(3, 50, 10, direction="reverse")
    assert chi.summary["cause"] == "completed" and np.nanmin(chi.theta()) < -5e-4
    after = {a["name"]: a for a in board.status()["axes"]}
    assert after["phi"]["position"] == positions["phi"]["position"], "chi's run left phi's alone"


def test_a_move_on_one_axis_ends_on_its_target(board):
    board.axes["theta"].step(2, 40, 10)
    board.axes["theta"].zero()
    move = board.axes["theta"].move_to(0.01, tolerance_rad=5e-5)
    assert move["stop_cause"] == "on_target" and abs(move["error_rad"]) <= 5e-5
    theta = {a["name"]: a for a in board.status()["axes"]}["theta"]
    assert theta["position"]["position_rad"] == pytest.approx(0.01, abs=1e-4)


def test_a_group_move_starts_every_axis_on_one_tick_and_each_ends_on_target(board):
    for axis in board.axes.values():
        axis.step(2, 40, 10)  # each axis's zero: its first reading
    targets = {"theta": 0.01, "phi": -0.02, "chi": 0.005}
    with pytest.raises(errors.BadArgument):
        board.move_to(targets, axis="theta")  # targets name the axes
    runs_before = board.status()["run"]["id"]
    moves = board.move_to(targets, tolerance_rad=5e-5)
    assert list(moves) == ["theta", "phi", "chi"], "in the board's order"
    for name, move in moves.items():
        assert move["stop_cause"] == "on_target", (name, move)
        assert abs(move["position_rad"] - targets[name]) <= 5e-5, (name, move)
    run = board.status()["run"]
    assert run["id"] == runs_before + 1, "one run for the group"
    summary = run["summary"]
    assert summary["cause"] == "completed"
    assert [(a["name"], a["cause"], a["output"]["state"]) for a in summary["axes"]] == [
        ("theta", "completed", "confirmed"), ("phi", "completed", "confirmed"),
        ("chi", "completed", "confirmed")]
    # One tick's start: every axis's first drive record is on the same deadline.
    drive = board.fetch("drive", 0, summary["samples"]["drive"])
    firsts = {int(a): drive["t_ns"][drive["axis"] == a][0] for a in np.unique(drive["axis"])}
    assert sorted(firsts) == [0, 1, 2] and len(set(firsts.values())) == 1
    # Each axis ends on its own: not all on the same record.
    lasts = [drive["t_ns"][drive["axis"] == a][-1] for a in range(3)]
    assert len(set(lasts)) > 1


def test_a_group_with_one_target_beyond_its_limits_is_refused_whole(board):
    before = board.status()
    with pytest.raises(errors.OutOfLimits) as refused:
        board.call("move_to", targets={"theta": 0.001, "phi": 99.0})
    assert "phi" in str(refused.value) and "target_rad" in str(refused.value)
    with pytest.raises(errors.BadArgument) as refused:
        board.call("move_to", targets={"theta": 0.001, "psi": 0.001})
    assert "psi" in str(refused.value)
    after = board.status()
    assert after["state"] == "idle" and after["run"]["id"] == before["run"]["id"], "nothing moved"


def test_a_board_e_stop_in_a_group_move_stops_every_axis(board_address):
    with Board(board_address) as mover, Board(board_address) as watcher:
        for axis in mover.axes.values():
            axis.step(1, 40, 10)
        args = mover.checked("move_to", {"targets": {"theta": 0.5, "phi": -0.5, "chi": 0.4}})
        with Run(mover, "move_to", args, True, raise_on_fault=False) as run:
            for block in run:
                if block.first > 2000:
                    assert watcher.estop() in ("running", "ramping_down", "fault")
                    break
            run.wait()
        summary = watcher.status()["run"]["summary"]
        assert summary["cause"] == "estop"
        for axis in summary["axes"]:
            assert axis["cause"] == "estop", axis
            assert axis["output"]["state"] == "confirmed", axis  # 0 V acknowledged
            assert axis["move"]["stop_cause"] == "estop", axis
        drive = watcher.fetch("drive", 0, summary["samples"]["drive"])
        for a in range(3):
            mine = drive[drive["axis"] == a]
            assert mine["V"][-1] == 0.0 and mine["phase"][-1] == 2, a  # stopped at 0 V
        assert watcher.reset_fault() == "idle"


def test_stop_of_one_axis_ends_it_alone(board_address):
    with Board(board_address) as mover:
        for axis in mover.axes.values():
            axis.zero()
        args = mover.checked("move_to", {"targets": {"theta": 0.002, "phi": -0.3, "chi": 0.002}})
        with Run(mover, "move_to", args, True, raise_on_fault=False) as run:
            for block in run:
                if block.first > 1000:
                    assert mover.axes["phi"].stop() == "running"
                    break
            run.wait()
        with pytest.raises(errors.BadArgument, match="psi"):
            mover.call("stop", axis="psi")
        summary = mover.status()["run"]["summary"]
        ends = {a["name"]: a for a in summary["axes"]}
        assert ends["phi"]["cause"] == "interrupted", ends["phi"]
        assert ends["phi"]["output"]["state"] == "confirmed"
        assert ends["phi"]["move"]["stop_cause"] == "interrupted"
        for name in ("theta", "chi"):
            assert ends[name]["move"]["stop_cause"] == "on_target", ends[name]
        # On the drive's records: phi stopped at 0 V well before its target.
        drive = mover.fetch("drive", 0, summary["samples"]["drive"])
        phi = drive[drive["axis"] == 1]
        assert phi["V"][-1] == 0.0 and phi["phase"][-1] == 2
        assert abs(ends["phi"]["move"]["position_rad"]) < 0.25


GROUP_MOVER = """
import sys
from piezo_rig.board import Board, Run
with Board(sys.argv[1]) as board:
    args = board.checked("move_to", {"targets": {"theta": -0.5, "phi": 0.5, "chi": -0.4}})
    with Run(board, "move_to", args, True, raise_on_fault=False) as run:
        for block in run:
            if block.first > 1000:
                print("moving", flush=True)
                sys.stdin.read()  # killed here
"""


def test_a_killed_client_or_a_lapsed_lease_stops_every_axis_of_a_group(board_address):
    with Board(board_address) as watcher:
        # The client killed with SIGKILL mid-move: the board's lease stops it.
        client = subprocess.Popen([sys.executable, "-c", GROUP_MOVER, board_address],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                  env=dict(os.environ))
        try:
            assert client.stdout.readline().strip() == "moving"
            client.send_signal(signal.SIGKILL)
        finally:
            client.wait(10)
        deadline = time.monotonic() + 20
        while watcher.status()["state"] in ("running", "ramping_down"):
            assert time.monotonic() < deadline
            time.sleep(0.05)
        summary = watcher.status()["run"]["summary"]
        assert [(a["name"], a["cause"]) for a in summary["axes"]] == [
            ("theta", "link_lost"), ("phi", "link_lost"), ("chi", "link_lost")]
        drive = watcher.fetch("drive", 0, summary["samples"]["drive"])
        for a in range(3):
            mine = drive[drive["axis"] == a]
            assert mine["V"][-1] == 0.0 and mine["phase"][-1] == 2, a
        assert watcher.reset_fault() == "idle"

    with Board(board_address) as mover:
        # A lease never renewed: the same, and the client hears it.
        args = mover.checked("move_to", {"targets": {"theta": 0.5, "chi": 0.4}})
        with Run(mover, "move_to", args, False, raise_on_fault=False) as run:
            summary = run.wait()
        assert summary["cause"] == "link_lost"
        assert [a["cause"] for a in summary["axes"]] == ["link_lost", "link_lost"]
        assert mover.reset_fault() == "idle"


def test_a_stalled_sensor_in_a_group_move_stops_its_axis_alone(tmp_path, source):
    # phi's sensor stops answering 0.5 s into each run (after its zero is taken).
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(tmp_path / "piezod.err"), sets=["axes.phi.sensor.sim.stall_at_s=0.5"])
    try:
        with Board(address) as board:
            for axis in board.axes.values():
                axis.step(2, 40, 10)
            args = board.checked("move_to", {"targets": {"theta": 0.01, "phi": 0.02, "chi": -0.005},
                                             "tolerance_rad": 5e-5})
            with Run(board, "move_to", args, True, raise_on_fault=False) as run:
                summary = run.wait()
            ends = {a["name"]: a for a in summary["axes"]}
            assert ends["phi"]["cause"] == "sensor_fault"
            assert ends["phi"]["move"]["stop_cause"] == "sensor_fault"
            assert ends["phi"]["output"]["state"] == "confirmed"
            for name in ("theta", "chi"):
                assert ends[name]["move"]["stop_cause"] == "on_target", ends[name]
            assert summary["cause"] == "sensor_fault"
            # phi's reads wait out their timeout from 0.5 s on; the others,
            # each on its own clock, keep their rate (docs/benchmarks.md has
            # the figures; the margin is for a loaded machine's real time).
            sensor, rate = run.sensor, board.hello()["sensor_rate_hz"]
            start = int(run.started["t0_ns"])
            for a, name in ((0, "theta"), (2, "chi")):
                t = (sensor[(sensor["axis"] == a) & (sensor["status"] == 0)]["t_request_ns"]
                     - start) * 1e-9
                stalled = t[t >= 0.6]
                if len(stalled) > 1:
                    per_s = (len(stalled) - 1) / (stalled[-1] - stalled[0])
                    print(f"{name}: {per_s:.0f} readings/s with phi's sensor stalled "
                          f"({per_s / rate:.0%} of {rate:g})")
                    assert per_s >= 0.5 * rate, (name, per_s)
            # Nothing lost: each axis's drive records run on the grid to its own end.
            drive = run.drive
            for a in range(3):
                mine = drive[drive["axis"] == a]
                assert np.all(np.diff(mine["t_ns"]) == 100_000), a
                assert mine["V"][-1] == 0.0 and mine["phase"][-1] == 2, a
            # phi's fault is latched on phi alone: the board is idle, theta
            # moves on, phi is refused until reset_fault clears it.
            status = board.status()
            assert status["state"] == "idle"
            faults = {a["name"]: a.get("fault") for a in status["axes"]}
            assert faults == {"theta": None, "phi": "sensor_fault", "chi": None}
            with pytest.raises(errors.FaultLatched, match="axis phi: its fault sensor_fault"):
                board.axes["phi"].step(1, 40, 10)
            with pytest.raises(errors.FaultLatched, match="phi"):
                board.move_to({"theta": 0.0, "phi": 0.0})
            assert board.axes["theta"].step(1, 40, 10).wait()["cause"] == "completed"
            assert board.reset_fault() == "idle"
            assert all(a.get("fault") is None for a in board.status()["axes"])
    finally:
        process.terminate()
        process.wait(10)


def test_an_axis_stopped_past_its_window_comes_back_inside_with_a_plain_move(tmp_path, source):
    """chi's window ends at 4 mrad: a run forward stops there with
    travel_limit, just past the end. A step further out is refused before
    anything moves; a plain move back to 0 at the defaults arrives, although
    its first periods carry the rotor forward (a stick stroke) before the
    slips take it back."""
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(tmp_path / "piezod.err"), sets=["axes.chi.safety.travel_max_rad=0.004"])
    try:
        with Board(address) as board:
            chi = board.axes["chi"]
            with pytest.raises(errors.RunEnded) as ended:
                with chi.run(60, 80, 10) as run:
                    run.wait()
            assert ended.value.cause == "travel_limit"
            status = board.status()
            at = next(a for a in status["axes"] if a["name"] == "chi")
            assert at["fault"] == "travel_limit" and at["position"]["position_rad"] >= 0.004, at
            board.reset_fault()
            run_id = (board.status().get("run") or {}).get("id")
            with pytest.raises(errors.OutOfLimits, match="upper end of its travel window") as out:
                chi.step(5, 60, 80)
            assert out.value.key == "direction"
            assert (board.status().get("run") or {}).get("id") == run_id, "nothing started"
            move = chi.move_to(0.0)
            assert move["stop_cause"] == "on_target", move
            summary = board.status()["run"]["summary"]
            assert summary["cause"] == "completed", summary
            # The first periods carried it further past the end, as measured:
            # the window's own end would have stopped this move.
            peak = float(np.max(board.last_run.theta()))
            print(f"chi back from {at['position']['position_rad'] * 1e3:.3f} mrad to "
                  f"{move['position_rad'] * 1e3:.4f} mrad in {move['steps']} steps, "
                  f"{peak * 1e3:.3f} mrad at most")
            assert peak > 0.004
    finally:
        process.terminate()
        process.wait(10)


def test_a_group_runs_arrays_are_each_axiss_own(board):
    """fit_arrays of a group move, axis by axis: each axis's drive and
    sensor records, its angles over its own radius; an axis the board lacks
    is refused naming the board's axes."""
    board.move_to({"theta": 0.002, "phi": -0.002}, tolerance_rad=5e-5)
    run = board.last_run
    assert run.axes == ["theta", "phi"] and run.axis == "theta"
    # Each axis's angles: its own readings, from the board's zero of that
    # axis, over its own sensor's radius (to the sensor's noise: a move that
    # takes its own zero averages 16 readings, where the client has the
    # run's first). Not its target: an axis that arrived first is still
    # pushed by the other's steps through the rig's crosstalk.
    zeros = {a["name"]: a["position"]["zero_displacement_m"] for a in board.status()["axes"]}
    radii = {a["name"]: a["r2_m"] for a in board.hello()["axes"]}
    for name in ("theta", "phi"):
        drive_t, drive_V, t, theta = run.fit_arrays(axis=name)
        index = list(board.axes).index(name)
        assert len(drive_t) == len(drive_V) == np.count_nonzero(run.drive["axis"] == index)
        mine = run.sensor[run.sensor["axis"] == index]
        good = mine[mine["status"] == 0]
        assert len(t) == len(theta) == len(good)
        expected = (good["displacement_m"] - zeros[name]) / radii[name]
        assert np.allclose(theta, expected, rtol=0, atol=5e-5), name
    with pytest.raises(ValueError, match="theta, phi, chi"):
        run.fit_arrays(axis="psi")
