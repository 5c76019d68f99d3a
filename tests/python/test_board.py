"""piezo_rig.board against a real piezod on the simulated rig: what a
researcher's script sees. Safety is read off the board (its status and
recorder), not off what the client believes it asked for."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import peers
from conftest import start_board
from piezo_rig import errors
from piezo_rig.board import Board


@pytest.fixture
def board(board_address):
    with Board(board_address) as b:
        if b.status()["state"] == "fault":
            b.reset_fault()
        yield b


def test_a_two_second_run_keeps_every_sample(board):
    hello = board.hello()
    assert hello["protocol"] == 2 and hello["sensor"]["r2_m"] > 0
    blocks = 0
    with board.run(V0=60, f=10, duration=2) as run:
        for block in run:
            assert block.stream in ("drive", "sensor")
            blocks += 1
    assert run.summary["cause"] == "completed"
    assert len(run.drive) == run.summary["samples"]["drive"] > 19000
    assert len(run.sensor) == run.summary["samples"]["sensor"] > 1900
    assert np.all(np.diff(run.drive["t_ns"]) > 0)
    assert run.drive["V"][-1] == 0.0 and run.drive["phase"][-1] == 2
    theta = run.theta()
    assert theta[0] == 0.0 and np.nanmax(theta) > 1e-3  # 60 V, 10 Hz, 2 s: forward
    assert blocks > 10
    assert board.status()["state"] == "idle"


def test_gaps_after_a_link_outage_are_fetched(board_address, source):
    # The link pulled for 0.4 s mid-run (a proxy that drops every
    # connection): the stream loses what was published meanwhile, the
    # client fetches it from the board's recorder.
    port = peers.free_port(2)
    proxy = subprocess.Popen([sys.executable, os.path.join(source, "tests", "protocol",
                                                           "link_proxy.py"),
                              str(port), board_address.rsplit(":", 1)[1], "0.4"])
    try:
        assert peers.wait_for_tcp(port)
        with Board(f"tcp://127.0.0.1:{port}", timeout=5) as board:
            with board.run(V0=40, f=20, duration=3, lease_s=3.0) as run:
                for block in run:
                    if block.stream == "sensor" and block.first > 500 and proxy.returncode is None:
                        proxy.send_signal(signal.SIGUSR1)
                        proxy.returncode = 0  # signalled once
    finally:
        proxy.kill()
        proxy.wait()
    assert run.summary["cause"] == "completed"
    assert run.gaps_fetched > 0
    assert len(run.drive) == run.summary["samples"]["drive"]
    assert len(run.sensor) == run.summary["samples"]["sensor"]
    step = np.diff(run.drive["t_ns"])
    assert np.all(step == step[0])  # one grid, nothing missing or doubled


def test_a_lost_lease_stops_the_drive_on_the_board(board):
    with pytest.raises(errors.RunEnded) as ended:
        with board.run(V0=40, f=10, duration=10, lease_s=0.3, renew=False) as run:
            run.wait()
    assert ended.value.cause == "link_lost"
    status = board.status()
    assert status["state"] == "fault" and status["fault"] == "link_lost"
    drive = board.fetch("drive", 0, 200000)
    assert drive["V"][-1] == 0.0 and drive["phase"][-1] == 2
    assert (drive["t_ns"][-1] - drive["t_ns"][0]) * 1e-9 < 5  # far from its 10 s
    board.reset_fault()


def test_a_move_reaches_its_target(board):
    move = board.move_to(0.01, tolerance_rad=50e-6)
    assert move["on_target"] and move["stop_cause"] == "on_target"
    assert abs(move["position_rad"] - 0.01) < 50e-6
    position = board.status()["position"]["position_rad"]
    assert abs(position - 0.01) < 1e-4  # the board's own reading at rest
    back = board.move_to(0.0, tolerance_rad=50e-6)
    assert abs(back["position_rad"]) < 50e-6


def test_steps_and_the_zero(board):
    run = board.step(3, V0=60, f=10, direction="reverse")
    assert run.summary["cause"] == "completed"
    assert run.theta()[-1] < 0
    position = board.zero()
    assert abs(position["position_rad"]) < 1e-5


def test_every_error_code_has_its_exception(board, board_address):
    with pytest.raises(errors.UnknownCommand):
        board.call("fly")
    with pytest.raises(errors.BadArgument) as bad:
        board.call("configure", V0=60.0, f=10.0, duration_s=0.5, lease=1.0)
    assert bad.value.key == "lease"
    limits = board.hello()["limits"]
    with pytest.raises(errors.OutOfLimits) as beyond:
        board.run(V0=limits["V_max"] + 10, f=10, duration=1)
    assert beyond.value.key == "V0"
    with pytest.raises(errors.BadState):
        board.call("lease")
    with pytest.raises(errors.TooLarge):
        board.call("clock", pad="x" * 70_000)
    nested = 0
    for _ in range(40):
        nested = [nested]
    with pytest.raises(errors.Malformed):
        board.call("clock", deep=nested)
    with pytest.raises(errors.NotAvailable):
        board.call("fetch", stream="sensor", first=10**12, count=5)
    # A second client watches a run it does not control: no stop, no zero,
    # but its e-stop is served, and the board's drive is at 0 V after it.
    with board.run(V0=40, f=10, duration=5, lease_s=1.0) as run:
        with Board(board_address) as other:
            with pytest.raises(errors.NotController):
                other.stop()
            with pytest.raises(errors.NotController):
                other.zero()
            other.estop()
        with pytest.raises(errors.RunEnded) as ended:
            run.wait()
    assert ended.value.cause == "estop"
    assert board.fetch("drive", 0, 200000)["V"][-1] == 0.0
    with pytest.raises(errors.FaultLatched):
        board.step(1, V0=40, f=10)
    board.reset_fault()
    # The codes no request here can provoke map all the same.
    for code in ("rate_limited", "internal"):
        error = errors.board_error("fetch", {"code": code, "key": "", "message": "m"})
        assert error.code == code and isinstance(error, errors.BoardError)


def test_no_reply_is_a_timeout(tmp_path):
    with Board("tcp://127.0.0.1:9", timeout=0.3) as nobody:
        with pytest.raises(errors.NoReply):
            nobody.hello()


def test_curve_keys(tmp_path):
    piezod = os.environ["PIEZOD_BINARY"]
    keys = tmp_path / "keys"
    keys.mkdir()
    for name in ("board", "host", "stranger"):
        subprocess.run([piezod, "keygen", "--out", str(keys), "--name", name], check=True,
                       capture_output=True)
    (keys / "authorized_keys").write_text((keys / "host.pub").read_text())
    config = tmp_path / "curve.toml"
    text = open(os.path.join(os.environ.get("PIEZO_SOURCE_DIR", "."), "configs",
                             "piezod-sim.toml")).read()
    text = text.replace("[piezod]\n", f'[piezod]\nsecret_key_file = "{keys}/board.key"\n'
                        f'authorized_keys_file = "{keys}/authorized_keys"\n', 1)
    config.write_text(text)
    process, address = peers.start_piezod(piezod, str(config), str(tmp_path / "err"))
    try:
        with Board(address, keys=(str(keys / "board.pub"), str(keys / "host.key"))) as b:
            assert b.hello()["protocol"] == 2
            with b.run(V0=40, f=10, duration=0.5) as run:
                run.wait()
            assert len(run.sensor) == run.summary["samples"]["sensor"]
        with Board(address, keys=(str(keys / "board.pub"), str(keys / "stranger.key")),
                   timeout=1.0) as stranger:
            with pytest.raises(errors.NoReply):
                stranger.hello()
        with Board(address, timeout=1.0) as plain:
            with pytest.raises(errors.NoReply):
                plain.hello()
    finally:
        process.terminate()
        process.wait(10)


def test_calibrate_installs_what_it_measured(board):
    calibration = board.calibrate()
    assert calibration["rad_per_V"] > 0 and calibration["noise_m"] > 0
    assert board.hello()["calibration"]["created"] == calibration["created"]
    assert board.set_calibration(None) is None
    assert board.hello()["calibration"] is None


def test_a_board_that_dies_mid_run_is_reported(tmp_path):
    process, address = start_board(tmp_path)
    try:
        with Board(address, timeout=1.0, silence_s=2.0) as board:
            started = time.monotonic()
            with pytest.raises(errors.NoReply, match="silent"):
                with board.run(V0=40, f=10, duration=30, lease_s=1.0) as run:
                    for block in run:
                        if process.poll() is None:
                            process.kill()
            assert time.monotonic() - started < 20
    finally:
        if process.poll() is None:
            process.kill()
        process.wait()
