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


def test_a_two_second_run_keeps_every_sample(board):
    hello = board.hello()
    assert hello["protocol"] == 6 and hello["axes"][0]["r2_m"] > 0
    assert "sensor" not in hello, "protocol 4: each axis's radius is in axes"
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
    proxy = peers.spawn([sys.executable, os.path.join(source, "tests", "protocol",
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
    position = board.axes["rotor"].status().position_rad
    assert abs(position - 0.01) < 1e-4  # the board's own reading at rest
    back = board.move_to(0.0, tolerance_rad=50e-6)
    assert abs(back["position_rad"]) < 50e-6


def test_a_move_with_a_forward_approach_passes_a_target_behind_it(board):
    start = board.axes["rotor"].status().position_rad
    move = board.move_to(start - 0.002, tolerance_rad=50e-6, approach="forward")
    assert move["on_target"] and abs(move["position_rad"] - (start - 0.002)) < 50e-6
    with pytest.raises(errors.BadArgument) as bad:
        board.move_to(start, approach="sideways")
    assert bad.value.key == "approach" and "either, forward, reverse" in str(bad.value)


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


def test_a_request_given_up_on_never_runs_on_the_board_that_comes_back(tmp_path):
    """A move sent while the board is down fails on the client, and is not
    run by the board when it comes back on its port; the client's next
    request names the board start it knew and is refused, nothing moving."""
    process, address = start_board(tmp_path)
    client = Board(address, timeout=1.0)
    first = client.hello()["board_id"]
    process.kill()
    process.wait()
    with pytest.raises(errors.NoReply):
        client.axes["rotor"].move_to(0.005)
    back = peers.restart_piezod(os.environ["PIEZOD_BINARY"], str(tmp_path / "piezod.toml"),
                                str(tmp_path / "piezod.err"), address)
    client.timeout = 10.0  # the board is back: a loaded machine may be slow to answer
    try:
        time.sleep(5)  # ZeroMQ's reconnection, at most 2 s apart
        with Board(address) as watcher:
            status = watcher.status()
            assert status["board_id"] != first, "a restarted board is a new board"
            assert "run" not in status and status["state"] == "idle", status
            assert status["requests"]["move_to"] == 0, status["requests"]
            with pytest.raises(errors.StaleBoard) as stale:
                client.axes["rotor"].move_to(0.005)
            assert stale.value.key == "board" and first in stale.value.message
            after = watcher.status()
            assert "run" not in after, after
            assert after["requests"]["move_to"] == 0, "refused at its first request"
            # The client dropped what it knew: asked again, it is served.
            assert client.board_id is None
            assert client.hello()["board_id"] == status["board_id"]
    finally:
        client.close()
        back.terminate()
        back.wait(10)


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
            assert b.hello()["protocol"] == 6
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
    assert board.axes["rotor"].info["calibration"]["created"] == calibration["created"]
    assert board.axes["rotor"].status().calibrated
    assert board.set_calibration(None) is None
    assert board.hello()["axes"][0]["calibration"] is None


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


# -- what a stranger met (each failed before its fix) ---------------------

def run_script(code, timeout=60):
    """A user's script in its own interpreter: a hang is a timeout here,
    not a hung test."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=timeout)


def test_leaving_a_board_ends_a_run_used_without_its_own_with(board_address):
    out = run_script(f"""
from piezo_rig.board import Board
with Board({board_address!r}) as board:
    run = board.run(V0=60, f=10, duration=0.5)
    run.wait()
print("left", run.summary["cause"])
""")
    assert out.returncode == 0 and out.stdout == "left completed\n", out.stderr
    assert "Error" not in out.stderr, out.stderr


def test_leaving_a_board_mid_run_stops_the_run_on_the_board(board, board_address):
    out = run_script(f"""
import time
from piezo_rig.board import Board
with Board({board_address!r}) as board:
    run = board.run(V0=60, f=10, duration=30)
    time.sleep(0.5)
print("left")
""")
    assert out.returncode == 0 and out.stdout == "left\n", out.stderr
    # The board, not the client, says how it ended: stopped at 0 V, no fault
    # (the stop was sent as the client left; the board ramps down on its own).
    deadline = time.monotonic() + 30
    while board.status()["state"] in ("running", "ramping_down") and time.monotonic() < deadline:
        time.sleep(0.05)
    status = board.status()
    assert status["state"] == "idle", status
    assert status["run"]["summary"]["cause"] == "interrupted"
    assert board.fetch("drive", 0, 400000)["V"][-1] == 0.0
    board.close()
    board.close()  # twice is harmless
    with pytest.raises(errors.ClientClosed):
        board.status()


def test_ctrl_c_while_streaming_is_a_keyboard_interrupt(board_address):
    # SIGINT from another process at a random moment of the stream, twelve
    # times: always KeyboardInterrupt, and the run stopped on the board.
    script = f"""
import sys
from piezo_rig.board import Board
with Board({board_address!r}) as board:
    try:
        with board.run(V0=40, f=10, duration=30) as run:
            print("streaming", flush=True)
            for block in run:
                pass
    except KeyboardInterrupt:
        print("KeyboardInterrupt", flush=True)
"""
    rng = np.random.default_rng(7)
    for _ in range(12):
        # The last child's run may still be ramping down on a loaded machine:
        # the next starts once the board is idle again.
        with Board(board_address) as watcher:
            deadline = time.time() + 30
            while watcher.status()["state"] != "idle" and time.time() < deadline:
                time.sleep(0.05)
        child = peers.spawn([sys.executable, "-c", script], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
        line = child.stdout.readline()
        if line != "streaming\n":
            assert False, child.communicate(timeout=30)[1]
        time.sleep(rng.uniform(0.05, 0.4))
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=30)
        assert out == "KeyboardInterrupt\n", err


def test_an_interrupt_while_a_run_waits_for_its_records_stops_it_and_the_follower_goes_on(board):
    # Ctrl-C lands in the caller's thread while it waits for the next
    # records: the run is stopped; the connection's follower, in a thread of
    # its own, follows on, and the next run gets every record.
    with pytest.raises(KeyboardInterrupt):
        with board.run(V0=40, f=10, duration=30) as run:
            messages = run._messages
            real_get = messages.get
            fired = []

            class Interrupting:
                def get(self, *args, **kwargs):
                    if not fired and run.sensor.size > 0:
                        fired.append(True)
                        raise KeyboardInterrupt
                    return real_get(*args, **kwargs)

            run._messages = Interrupting()
            for _ in run:
                pass
    assert fired
    status = board.status()
    assert status["state"] == "idle" and status["run"]["summary"]["cause"] == "interrupted"
    assert board.follower.snapshot.reachable
    with board.run(V0=40, f=10, duration=0.5) as again:
        summary = again.wait()
    assert len(again.sensor) == summary["samples"]["sensor"]


def test_refusals_pickle_for_a_worker_process(board):
    import pickle

    with pytest.raises(errors.OutOfLimits) as beyond:
        board.run(V0=board.hello()["limits"]["V_max"] + 10, f=10, duration=1)
    back = pickle.loads(pickle.dumps(beyond.value))
    assert type(back) is errors.OutOfLimits and back.key == "V0"
    assert str(back) == str(beyond.value) and back.message == beyond.value.message
    ended = pickle.loads(pickle.dumps(errors.RunEnded("move_to", "stalled", {"cause": "x"})))
    assert ended.cause == "stalled" and ended.summary == {"cause": "x"}
    assert str(ended) == "move_to ended: stalled"
    unknown = errors.board_error("fetch", {"code": "newer_code", "key": "k", "message": "m"})
    again = pickle.loads(pickle.dumps(unknown))
    assert again.code == "newer_code" and str(again) == str(unknown)


def test_a_second_clients_refusal_says_its_command_once(board, board_address):
    with board.run(V0=40, f=10, duration=3, lease_s=1.0) as run:
        with Board(board_address) as other:
            with pytest.raises(errors.NotController) as refused:
                other.stop()
        board.stop()
        run.wait()
    text = str(refused.value)
    assert text.startswith("stop: not_controller: ") and text.count("stop:") == 1, text


def test_calibrate_shows_its_progress(board, capfd):
    board.calibrate()
    err = capfd.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("calibrate: ")]
    assert len(lines) >= 5, err
    # The board's own fraction, rising to near the end (it read "14 s of
    # about 1 s" from a planned length that was not the experiment's).
    done = [int(line.split()[1]) for line in lines if "% done after" in line]
    assert len(done) >= 5 and done == sorted(done) and done[-1] >= 70, err
    board.set_calibration(None)


def test_a_refused_move_prints_one_json_object_and_keeps_its_config(board, board_address,
                                                                     piezo, tmp_path):
    import json
    import tomllib

    board.estop()  # latched: the board refuses the move
    out = subprocess.run([piezo.binary, "move", "--to", "0.001", "--rig", board_address, "--json",
                          "--out", str(tmp_path / "refused")], capture_output=True, text=True)
    board.reset_fault()
    assert out.returncode == 1, out.stderr
    reply = json.loads(out.stdout)  # one object, nothing else on stdout
    assert out.stdout.count("\n") == 1
    assert reply["status"] == "failed" and reply["code"] == "fault_latched", reply
    assert "reset_fault" in reply["error"]
    with open(tmp_path / "refused" / "config.toml", "rb") as f:
        used = tomllib.load(f)
    assert used["drive"]["V0"] > 0 and used["model"]["sigma0"] > 0
    assert used["rig"]["address"] == board_address and used["run"]["duration_s"] > 0
    # A bad option is one object too (bad input, exit 2).
    bad = subprocess.run([piezo.binary, "move", "--to", "0.001", "--rig", board_address, "--json",
                          "--tolerance", "-1", "--out", str(tmp_path / "bad")],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and json.loads(bad.stdout)["code"] == "bad_input", bad.stdout


def test_addresses_follow_the_transport_rule():
    """The stream's address as docs/protocol.md's "Transport" gives it, and
    an address piezo refuses refused at once."""
    from piezo_rig.board import stream_address
    assert stream_address("tcp://127.0.0.1:5555") == "tcp://127.0.0.1:5556"
    assert stream_address("ipc:///run/piezod") == "ipc:///run/piezod-stream"
    with pytest.raises(ValueError, match="allowed tcp://HOST:PORT"):
        Board("udp://127.0.0.1:5555")
    # No port: that, not the CURVE keys a network address needs.
    with pytest.raises(ValueError, match="tcp://127.0.0.1'.*with a port"):
        Board("tcp://127.0.0.1")


@pytest.mark.parametrize("timeout,error,words", [
    (-1, ValueError, "Board: timeout: -1 s"), (float("nan"), ValueError, "Board: timeout: nan s"),
    ("3", TypeError, "Board: timeout: expected a number of seconds; got str")])
def test_a_timeout_that_would_fail_every_call_is_refused(timeout, error, words):
    with pytest.raises(error, match=words):
        Board("tcp://127.0.0.1:5555", timeout=timeout)


def test_numbers_numpy_hands_out_just_work(board):
    with board.run(V0=np.float32(60), f=np.int64(10), duration=np.float64(0.2)) as run:
        run.wait()
    assert run.summary["cause"] == "completed"
    stepped = board.step(np.int64(3), np.float32(60), np.float64(10))
    assert stepped.summary["cause"] == "completed"
    with pytest.raises(TypeError, match="configure: V0: expected a number, text or flag; got "
                                        "complex"):
        board.run(V0=60j, f=10, duration=0.2)


def test_a_calibration_below_0_v_is_refused_naming_the_range(board):
    with pytest.raises(errors.OutOfLimits, match=r"V0.*-1 V is beyond the board's limits; allowed: \(0, 80\] V"):
        board.calibrate(V0=-1)


def test_closing_the_board_from_another_thread_mid_run_is_client_closed(board_address):
    import threading
    board = Board(board_address)
    with pytest.raises(errors.ClientClosed, match="closed while the run was being received"):
        with board.run(V0=60, f=10, duration=30) as run:
            threading.Timer(0.5, board.close).start()
            for _ in run:
                pass
    with Board(board_address) as other:  # the board stopped the run itself
        deadline = time.monotonic() + 10
        while other.status()["state"] != "idle" and time.monotonic() < deadline:
            time.sleep(0.1)
        assert other.status()["state"] == "idle"


def test_a_held_estop_button_is_reset_only_once_released(tmp_path):
    """The board's own e-stop input (the simulated rig's button, pressed
    0.3 s into each run and held 3 s): the run ends `estop` at 0 V on the
    simulated amplifier; reset_fault is refused while the button is down,
    and so is a new run; released, the reset clears the fault."""
    process, address = start_board(tmp_path, "\n[lines.sim]\nestop_at_s = 0.3\n"
                                             "estop_hold_s = 3.0\n")
    try:
        with Board(address) as board:
            started = time.monotonic()
            with pytest.raises(errors.RunEnded) as ended:
                with board.run(V0=60, f=10, duration=5) as run:
                    run.wait()
            assert ended.value.cause == "estop"
            summary = ended.value.summary
            assert summary["output"]["state"] == "confirmed"
            assert run.drive["V"][-1] == 0.0 and run.drive["phase"][-1] == 2
            status = board.status()
            assert status["state"] == "fault" and status["fault"] == "estop"
            # Still held (the run started after `started`): refused, naming
            # the button, and the fault stays.
            assert time.monotonic() - started < 3.0, "the machine was too slow to see the hold"
            with pytest.raises(errors.BadState, match="still pressed"):
                board.reset_fault()
            with pytest.raises(errors.FaultLatched, match="reset_fault"):
                board.run(V0=60, f=10, duration=0.2)
            assert board.status()["fault"] == "estop"
            # Refused until the release (0.3 + 3 s after the run's start,
            # which came after `started`), then the reset clears it.
            while True:
                try:
                    board.reset_fault()
                    break
                except errors.BadState:
                    assert time.monotonic() - started < 10
                    time.sleep(0.05)
            assert time.monotonic() - started >= 3.3
            assert board.status()["state"] == "idle"
            # A run again; the button is pressed 0.3 s into each run, so
            # this one is over well before (its 50 ms and the ramp down).
            with board.run(V0=20, f=10, duration=0.05) as again:
                again.wait()
            assert again.summary["cause"] == "completed"
    finally:
        process.terminate()
        process.wait(10)


def test_a_board_runs_arrays_go_into_identify(board):
    from piezo_rig import model
    with board.run(V0=60, f=10, duration=0.5) as run:
        run.wait()
    drive_t, drive_V, t, theta = run.fit_arrays()
    # The drive's times carry the board's output latency, as a logged run's do.
    assert drive_t[0] == pytest.approx(run.t(run.drive)[0] + board.hello()["output_latency_s"])
    assert len(t) == len(theta) and not np.isnan(theta).any()
    fit = model.identify(run.fit_arrays(), free=["F_N"], max_iterations=5)
    assert fit.rmse_rad < fit.initial_rmse_rad or fit.rmse_rad < 1e-6


def test_a_board_limited_to_60_v_is_refused_70_v_by_every_client_before_sending(tmp_path, piezo,
                                                                                   source):
    """A board whose config limits V0 to 60 V describes V0 so, and both the
    Python client and `piezo move` refuse 70 V from that description, naming
    the board's limit, before anything is sent (the board counts every
    request it gets); a move within it is one `move_to`, nothing before it."""
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "piezod-sim.toml"),
        str(tmp_path / "piezod.err"), sets=("drive.V_max=60", "drive.V0=50"))
    try:
        with Board(address) as board:
            V0 = next(a for a in board.arguments("move_to") if a["name"] == "V0")
            assert (V0["max"], V0["limit"], V0["unit"]) == (60, "V_max", "V")
            before = board.status()["requests"]
            refusals = (lambda: board.move_to(0.001, V0=70),
                        lambda: board.run(V0=70, f=10, duration=1),
                        lambda: board.step(1, V0=70, f=10),
                        lambda: board.calibrate(V0=70, progress=False))
            for refused_call in refusals:
                with pytest.raises(errors.OutOfLimits) as refused:
                    refused_call()
                assert refused.value.key == "V0"
                assert "allowed: (0, 60] V (the board's V_max is 60 V)" in str(refused.value)
            with pytest.raises(errors.BadArgument) as unknown:
                board.move_to(0.001, tolerance=1e-4)
            assert unknown.value.key == "tolerance" and "tolerance_rad" in str(unknown.value)
            with pytest.raises(errors.BadArgument) as choice:
                board.move_to(0.001, approach="sideways")
            assert "either, forward, reverse" in str(choice.value)

            cli = subprocess.run([piezo.binary, "move", "--rig", address, "--to", "0.001",
                                  "--V0", "70", "--out", str(tmp_path / "refused")],
                                 capture_output=True, text=True)
            assert cli.returncode == 2, cli.stderr
            assert "V0" in cli.stderr and "the board's V_max is 60 V" in cli.stderr
            assert not (tmp_path / "refused").exists()
            after = board.status()["requests"]
            sent = {cmd: after[cmd] - before[cmd] for cmd in after
                    if after[cmd] != before[cmd] and cmd not in ("status", "describe", "hello")}
            assert sent == {}, "a refused request reached the board"

            # Each literal default of the dictionary, passed back, is taken.
            defaults = {a["name"]: a["default"] for a in board.arguments("move_to")
                        if a["default"] is not None}
            move = board.move_to(0.001, **defaults)
            assert move["stop_cause"] == "on_target"
            assert move["stop_cause"] in board.describe()["names"]["move_ends"]
            before = board.status()["requests"]
            moved = piezo("move", "--rig", address, "--to", "0.002", "--json",
                          "--out", str(tmp_path / "moved"))
            assert moved["on_target"]
            after = board.status()["requests"]
            assert after["move_to"] - before["move_to"] == 1
            assert after["configure"] == before["configure"], "piezo move sent a configure"
            assert after["start"] == before["start"]
    finally:
        process.terminate()
        process.wait(10)


def test_frames_decode_by_the_layout_the_board_describes(board):
    """The client holds no copy of the frame layout: it takes the board's,
    and refuses a frame that does not match it."""
    from piezo_rig.frames import FrameError
    layout = board.frame_layout
    assert layout.record("drive").names == ("t_ns", "V", "phase", "status", "move_state", "axis")
    assert layout.record("sensor")["displacement_m"] == np.dtype("<f8")
    with board.run(V0=60, f=10, duration=0.2) as run:
        for _ in run:
            pass
    recorded = board.fetch("drive", 0, 100)
    assert recorded.dtype.names == layout.record("drive").names and len(recorded) == 100
    frame = board.call("fetch", stream="sensor", first=0, count=3)["frame"]
    stream, first, records = layout.decode(frame)
    assert (layout.names[stream], first, len(records)) == ("sensor", 0, 3)
    for bad in (frame[:10], b"XXXX" + frame[4:], frame + b"\0"):
        with pytest.raises(FrameError):
            layout.decode(bad)
