"""Fly scans on the simulated board of three axes (configs/three-axes.toml)
through piezo_rig and a real piezod: a group scan, each axis at its own
velocity, checked against the run's own sensor records (the angle the
board filtered, recomputed here from the readings it logged), its pulses
counted, refusals that move nothing, and the stops every run has."""

import json
import os
import subprocess

import h5py
import numpy as np
import pytest

import peers
from piezo_rig import errors
from piezo_rig.board import Board, Run
from piezo_rig.log import open_run

STEP = 0.002  # rad between trigger positions
STEP_TEXT = "0.002"
FILTER = 8    # readings the board averages (docs/protocol.md, "Scans")


@pytest.fixture(scope="module")
def board_address(tmp_path_factory, source):
    where = tmp_path_factory.mktemp("scans")
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(where / "piezod.err"), sets=[f"piezod.calibration_file={where / 'calibration.json'}"])
    with Board(address) as board:
        for axis in board.axes.values():
            axis.calibrate(progress=False)
    yield address
    process.terminate()
    process.wait(10)


@pytest.fixture(autouse=True)
def a_latched_fault_stays_with_its_test(request):
    """The module's tests share one board: whatever a test leaves latched
    (a failed assertion before its reset_fault) is cleared after it."""
    yield
    if "board_address" in request.fixturenames:
        with Board(request.getfixturevalue("board_address")) as board:
            if board.status()["state"] == "fault":
                board.reset_fault()


def ranges(board):
    return {a["name"]: (a["base_rate_rad_per_s"], a["velocity_max_rad_per_s"])
            for a in board.hello()["axes"]}


def filtered_angles(scan, axis):
    """The angle the board follows, recomputed from the run's records: each
    good reading averaged with the 7 before it; with each reading's time
    from t0 (its answer's)."""
    sensor = scan.records_of(axis, scan.sensor)
    good = sensor[sensor["status"] == 0]
    theta = scan.theta(good, axis)
    mean = np.convolve(theta, np.ones(FILTER) / FILTER, mode="valid")
    t = (good["t_response_ns"][FILTER - 1:] - scan.started["t0_ns"]) * 1e-9
    return t, mean


def test_hello_gives_each_calibrated_axis_its_velocity_range_and_trigger_line(board):
    for name, (base, top) in ranges(board).items():
        assert 0 < base < top, name
    assert all(a["trigger"] for a in board.hello()["axes"]), "the simulated lines wire every axis"


def test_a_group_scan_runs_each_span_at_its_velocity_and_fires_each_position_once(board):
    r = ranges(board)
    spans = {"theta": (0.01, 0.05), "phi": (0.0, -0.03), "chi": (-0.01, 0.02)}
    # Each axis its own velocity: a third, a half and two thirds up its range.
    v = {name: base + share * (top - base)
         for (name, (base, top)), share in zip(r.items(), (0.33, 0.5, 0.66))}
    scans = {name: {"from_rad": a, "to_rad": b, "velocity_rad_per_s": v[name],
                    "trigger_step_rad": STEP} for name, (a, b) in spans.items()}
    with board.scan(scans=scans) as scan:
        streamed = list(scan.triggers())
        scan.wait()
    assert scan.axes == ["theta", "phi", "chi"]
    rate = board.hello()["sensor_rate_hz"]
    for name, (a, b) in spans.items():
        account = scan.accounts[name]
        assert account["stop_cause"] == "on_target" and account["stage"] == "done", account
        direction = np.sign(b - a)
        # The span's mean velocity, from the board and from the records.
        assert account["measured_velocity_rad_per_s"] == pytest.approx(v[name], rel=0.05), name
        t, angle = filtered_angles(scan, name)
        # The span: from the last reading before B that passed A (the
        # approach may have started beyond A) to the first that passed B.
        at_b = int(np.argmax(direction * (angle - b) >= 0))
        at_a = int(np.nonzero(direction * (angle[:at_b] - a) < 0)[0][-1]) + 1
        assert abs(b - a) / (t[at_b] - t[at_a]) == pytest.approx(v[name], rel=0.05), name
        assert account["ripple_10_rad_per_s"] < 0.2 * v[name]
        assert account["model_velocity_rad_per_s"] > 0
        # floor((B - A) / STEP) + 1 pulses, each k once, in order.
        pulses = scan.pulses(name)
        expected = int(np.floor(abs(b - a) / STEP + 1e-9)) + 1
        assert [p.k for p in pulses] == list(range(expected)), name
        assert account["triggers"]["fired"] == expected and account["triggers"]["unreported"] == 0
        assert sorted((p.k for p in streamed if p.axis == name)) == list(range(expected))
        # Each pulse's angle is the filtered angle of the reading that first
        # passed its position: past it by no more than that reading's travel
        # (the reading before had not passed it).
        for p in pulses:
            i = int(np.argmin(np.abs(t - p.reading_s)))
            assert abs(t[i] - p.reading_s) < 0.5 / rate, (name, p)
            assert p.angle_rad == pytest.approx(angle[i], abs=1e-9), (name, p)
            past = direction * (p.angle_rad - p.position_rad)
            travel = direction * (angle[i] - angle[i - 1])
            assert 0 <= past <= travel + 1e-12, (name, p)
            assert p.edge_s >= p.reading_s


def test_a_velocity_beyond_the_range_or_a_step_under_the_noise_rule_is_refused_moving_nothing(
        board):
    before = board.status()
    base, top = ranges(board)["theta"]
    with pytest.raises(errors.OutOfLimits) as refused:
        board.scan(0.0, 0.02, 1.5 * top, axis="theta")
    assert "velocity_rad_per_s" in str(refused.value) and f"{top:.4g}" in str(refused.value)
    with pytest.raises(errors.OutOfLimits) as refused:
        board.scan(0.0, 0.02, 0.5 * base, axis="theta")
    assert "base rate" in str(refused.value)
    with pytest.raises(errors.OutOfLimits) as refused:
        board.scan(0.0, 0.02, 0.5 * (base + top), axis="theta", trigger_step_rad=1e-6)
    assert "trigger_step_rad" in str(refused.value) and "at least" in str(refused.value)
    with pytest.raises(errors.OutOfLimits) as refused:  # one axis of a group: none moves
        board.scan(scans={"theta": {"from_rad": 0, "to_rad": 0.02, "velocity_rad_per_s": top},
                          "phi": {"from_rad": 0, "to_rad": 0.02, "velocity_rad_per_s": 9.0}})
    assert "scans.phi" in str(refused.value) or "phi" in str(refused.value)
    with pytest.raises(errors.OutOfLimits) as refused:  # chi's travel window is ±0.5 rad
        board.scan(0.0, 0.499, 0.5 * (base + top), axis="chi")
    assert "travel window" in str(refused.value)
    after = board.status()
    assert after["state"] == "idle"
    assert (after.get("run") or {}).get("id") == (before.get("run") or {}).get("id"), "no run"


def test_an_uncalibrated_axis_is_refused_naming_the_missing_calibration(board):
    calibration = board.hello()["axes"][1]["calibration"]
    board.set_calibration(None, axis="phi")
    try:
        with pytest.raises(errors.BadState) as refused:
            board.scan(0.0, 0.02, 0.01, axis="phi")
        assert "calibrat" in str(refused.value)
        assert board.hello()["axes"][1]["velocity_max_rad_per_s"] is None
    finally:
        board.set_calibration(calibration, axis="phi")


def test_an_e_stop_stops_a_scan_at_0_V_and_its_summary_keeps_the_pulses_fired(board_address):
    with Board(board_address) as mover, Board(board_address) as watcher:
        base, top = ranges(mover)["theta"]
        with mover.scan(0.0, 0.1, 0.5 * (base + top), axis="theta",
                        trigger_step_rad=STEP) as scan:
            for pulse in scan.triggers():
                if pulse.k == 5:
                    watcher.estop()
            with pytest.raises(errors.RunEnded) as ended:
                scan.wait()
        assert "estop" in str(ended.value)
        summary = scan.summary
        axis = summary["axes"][0]
        assert axis["cause"] == "estop" and axis["output"]["state"] == "confirmed"
        assert axis["scan"]["stop_cause"] == "estop"
        pulses = scan.pulses("theta")
        assert 6 <= len(pulses) < 51, "the pulses until the stop, and no more"
        assert [p.k for p in pulses] == list(range(len(pulses)))
        assert axis["scan"]["triggers"]["fired"] == len(pulses)
        # The drive's own record: the last one written is 0 V.
        drive = scan.records_of("theta", scan.drive)
        assert drive["V"][-1] == 0.0
        mover.reset_fault()


def test_a_lease_that_lapses_stops_a_scan_at_0_V_with_its_pulses_kept(board_address):
    with Board(board_address) as client:
        base, top = ranges(client)["theta"]
        # Long enough that the lapsed lease, not the scan's end, stops it
        # (the scan takes some 18 s), and that pulses fire before it lapses
        # however slowly the scan gets going (the first is at the start).
        args = client.checked("scan", {"axis": "theta", "from_rad": 0.0, "to_rad": 0.6,
                                        "velocity_rad_per_s": 0.5 * (base + top),
                                        "trigger_step_rad": STEP, "lease_s": 2.0})
        run = Run(client, "scan", args, renew=False, raise_on_fault=False)
        summary = run.wait()
        run.close()
        axis = summary["axes"][0]
        assert summary["cause"] == "link_lost" and axis["scan"]["stop_cause"] == "link_lost"
        assert axis["output"]["state"] == "confirmed"
        assert run.records_of("theta", run.drive)["V"][-1] == 0.0
        pulses = axis["scan"]["pulses"]
        assert pulses and [p["k"] for p in pulses] == list(range(len(pulses)))
        assert axis["scan"]["triggers"]["fired"] == len(pulses) < 301
        client.reset_fault()


def test_a_rotor_held_at_an_end_stop_stops_the_scan_stalled(tmp_path, source):
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(tmp_path / "piezod.err"), sets=["axes.theta.plant.end_stop_rad=0.1"])
    try:
        with Board(address) as board:
            board.axes["theta"].calibrate(progress=False)
            base, top = ranges(board)["theta"]
            with board.scan(0.04, 0.14, 0.5 * (base + top), axis="theta",
                            trigger_step_rad=STEP) as scan:
                with pytest.raises(errors.RunEnded):
                    scan.wait()
            account = scan.accounts["theta"]
            assert account["stop_cause"] in ("stalled", "sensor_implausible"), account
            assert scan.summary["axes"][0]["output"]["state"] == "confirmed"
            fired = scan.pulses("theta")
            assert fired and all(p.position_rad <= 0.1 + 1e-9 for p in fired)
            assert fired[-1].position_rad >= 0.1 - 2 * STEP, "every position before the stop"
    finally:
        process.terminate()
        process.wait(10)


def test_piezo_scan_logs_each_axis_s_pulses_as_the_board_fired_them(board_address, piezo, tmp_path):
    with Board(board_address) as board:
        r = ranges(board)
    v = {name: 0.5 * (base + top) for name, (base, top) in r.items()}
    out = piezo("scan", "--rig", board_address, "--from", "theta=0", "--to", "theta=0.02",
                "--velocity", f"theta={v['theta']}", "--from", "chi=0.01", "--to", "chi=-0.01",
                "--velocity", f"chi={v['chi']}", "--trigger-step", str(STEP),
                "--trigger-width", "theta=0.0005", "--out", str(tmp_path / "run"), "--json")
    assert out["scanned"] and sorted(out["scans"]) == ["chi", "theta"]
    assert open_run(tmp_path / "run", axis="chi").axes == ["theta", "chi"], "the board's order"
    with Board(board_address) as board:  # the board's own account of its last run
        summary = {a["name"]: a for a in board.status()["run"]["summary"]["axes"]}
    for name, span in (("theta", 0.02), ("chi", 0.02)):
        log = open_run(tmp_path / "run", axis=name)
        expected = int(np.floor(span / STEP + 1e-9)) + 1
        assert list(log.triggers["k"]) == list(range(expected)), name
        assert out["scans"][name]["triggers"]["fired"] == expected
        assert not log.triggers["late"].any()
        # The log's rows are the board's own account of each pulse.
        board_pulses = summary[name]["scan"]["pulses"]
        assert np.allclose(log.triggers["angle_rad"], [p["angle_rad"] for p in board_pulses])
        assert np.allclose(log.triggers["edge_s"], [p["edge_s"] for p in board_pulses])
    with h5py.File(tmp_path / "run" / "run.h5") as f:
        logged = json.loads(f["axes/theta"].attrs["summary"])
    assert logged["scan"]["measured_velocity_rad_per_s"] == pytest.approx(v["theta"], rel=0.05)
    assert out["scans"]["theta"]["triggers"]["width_s"] == 0.0005
    assert out["scans"]["chi"]["triggers"]["width_s"] == 0.001


def test_the_pulses_end_where_trigger_end_rad_says(board):
    base, top = ranges(board)["theta"]
    with pytest.raises(errors.BadArgument) as refused:
        board.scan(0.0, 0.04, 0.5 * (base + top), axis="theta", trigger_step_rad=STEP,
                   trigger_end_rad=0.03, trigger_pulses=4)
    assert "trigger_end_rad" in str(refused.value)
    with board.scan(0.0, 0.04, 0.5 * (base + top), axis="theta", trigger_step_rad=STEP,
                    trigger_end_rad=0.03) as scan:
        scan.wait()
    assert [p.k for p in scan.pulses("theta")] == list(range(16))
    assert scan.pulses("theta")[-1].position_rad == pytest.approx(0.03)


def test_an_e_stopped_scan_s_log_is_marked_failed_and_keeps_the_pulses_fired(piezo, tmp_path,
                                                                           source):
    """`piezo scan` on the board in its own process, its simulated e-stop
    pressed mid-scan: the run ends failed at 0 V, and its log holds every
    pulse the board fired until then, as the board's summary lists them."""
    config = ["--config", os.path.join(source, "configs", "three-axes.toml"), "--set",
              f"piezod.calibration_file={tmp_path / 'calibration.json'}"]
    piezo("calibrate", *config, "--axis", "theta", "--out", str(tmp_path / "calibration"))
    out = subprocess.run([piezo.binary, "scan", *config, "--set", "lines.sim.estop_at_s=2.5",
                          "--axis", "theta", "--from", "0", "--to", "0.1", "--velocity", "0.02",
                          "--trigger-step", STEP_TEXT, "--json", "--out", str(tmp_path / "run")],
                         capture_output=True, text=True)
    assert out.returncode == 1, out.stderr
    result = json.loads(out.stdout)
    assert result["stop_cause"] == "estop" and not result["scanned"]
    account = result["scans"]["theta"]
    assert account["stop_cause"] == "estop" and 0 < account["triggers"]["fired"] < 51
    log = open_run(tmp_path / "run")
    assert log.status == "failed" and log.stop_cause == "estop"
    assert list(log.triggers["k"]) == list(range(account["triggers"]["fired"]))
    assert log.drive["V"].iloc[-1] == 0.0
