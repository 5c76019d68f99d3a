"""The connection's one follower of the board's stream (piezo_rig.follower)
as a client sees it: a fresh board's every axis has a position at once, a
rotor turned by the simulated rig at 0 V is reported with its size, and a
follower whose socket fails, or that hears malformed and unexpected
messages, or whose board goes away, says so and follows again when the
board is back -- never a silent stale view."""

import os
import re
import signal
import subprocess
import time

import msgpack
import pytest
import zmq

import peers
from board_link import Link
from conftest import start_board
from piezo_rig.board import Board
from piezo_rig.errors import NoReply


def wait_for(condition, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.02)
    raise AssertionError(f"{what}: not within {seconds} s")


@pytest.fixture
def board_address(tmp_path):
    process, address = start_board(tmp_path)
    yield address
    process.terminate()
    process.wait(10)


def test_a_fresh_board_has_every_axis_position_within_a_second(tmp_path):
    started = time.monotonic()
    process, address = start_board(tmp_path)
    try:
        with Board(address) as board:
            wait_for(lambda: board.axes["rotor"].status().position_rad is not None, 10,
                     "a position at rest")
            took = time.monotonic() - started
            rotor = board.axes["rotor"].status()
            print(f"a position {took:.2f} s after piezod was started (its listening included)")
            assert abs(rotor.position_rad) < 1e-4 and rotor.noise_rad > 0
            assert rotor.age_s is not None and not rotor.moved
        # piezo status says the same, with the noise and the age of the reading.
        shown = subprocess.run([os.environ["PIEZO_BINARY"], "status", "--rig", address],
                               capture_output=True, text=True, timeout=30)
        assert shown.returncode == 0, shown.stderr
        assert re.search(r"axis rotor +-?\d+\.\d+ mrad from its zero, noise \d+\.\d+ mrad, "
                         r"read \d+\.\d+ s ago", shown.stdout), shown.stdout
    finally:
        process.terminate()
        process.wait(10)


def test_a_rotor_turned_at_rest_is_reported_with_its_size(tmp_path, source):
    # The simulated rig as a Modbus device, its hand register turns the
    # rotor by 3 mrad with the drive at 0 V: the board sees it, says how far.
    config = os.path.join(source, "configs", "modbus-hil.toml")
    port = peers.free_port()
    sets = [f"sensor.modbus.port={port}", f"drive.modbus-ao.port={port}"]
    rig = peers.spawn([os.environ["PIEZO_BINARY"], "rig-sim", "--config", config,
                       *[a for s in sets for a in ("--set", s)]],
                      stdout=subprocess.DEVNULL, stderr=open(tmp_path / "rig.err", "w"))
    process, address = peers.start_piezod(os.environ["PIEZOD_BINARY"], config,
                                          str(tmp_path / "piezod.err"), sets=sets)
    try:
        with Board(address) as board:
            wait_for(lambda: board.axes["rotor"].status().position_rad is not None, 10,
                     "a position at rest")
            before = board.axes["rotor"].status().position_rad
            from pymodbus.client import ModbusTcpClient
            hand = ModbusTcpClient("127.0.0.1", port=port)
            assert hand.connect()
            assert not hand.write_register(0x1010, 3000).isError()  # 3000 urad
            hand.close()
            wait_for(lambda: board.follower.snapshot.moved, 10, "the move at rest reported")
            event = board.follower.snapshot.moved[-1]
            assert event["axis"] == "rotor"
            assert event["moved_rad"] == pytest.approx(3e-3, abs=1e-4)
            wait_for(lambda: board.axes["rotor"].status().moved, 5, "the axis flagged")
            rotor = board.axes["rotor"].status()
            assert rotor.position_rad - before == pytest.approx(3e-3, abs=1e-4)
            assert rotor.moved_rad == pytest.approx(3e-3, abs=1e-4)
            status = {a["name"]: a for a in board.status()["axes"]}
            assert status["rotor"]["rest"]["moved"]
            # The next run starts from where the rotor is now: a step forward
            # begins at the turned angle.
            run = board.step(2, 40, 10)
            theta0 = run.sensor["displacement_m"][0]
            zero = status["rotor"]["position"]["zero_displacement_m"]
            r2 = board.hello()["axes"][0]["r2_m"]
            assert (theta0 - zero) / r2 == pytest.approx(rotor.position_rad, abs=1e-4)
            after = board.axes["rotor"].status()
            assert not after.moved, "a run's end begins a new rest"
    finally:
        process.terminate()
        process.wait(10)
        rig.terminate()
        rig.wait(10)


def test_a_sensor_that_stops_answering_at_rest_is_said_stale(tmp_path, source):
    # The sensor (rig-sim) stops answering once the board has a position
    # (the process is stopped, its requests wait unanswered): the board's
    # readings at rest time out, and the axis says so; then it answers
    # again, the requests it missed with it.
    config = os.path.join(source, "configs", "modbus-hil.toml")
    port = peers.free_port()
    sets = [f"sensor.modbus.port={port}", f"drive.modbus-ao.port={port}"]
    rig = peers.spawn([os.environ["PIEZO_BINARY"], "rig-sim", "--config", config,
                       *[a for s in sets for a in ("--set", s)]],
                      stdout=subprocess.DEVNULL, stderr=open(tmp_path / "rig.err", "w"))
    process, address = peers.start_piezod(os.environ["PIEZOD_BINARY"], config,
                                          str(tmp_path / "piezod.err"), sets=sets)
    try:
        with Board(address) as board:
            wait_for(lambda: board.axes["rotor"].status().position_rad is not None, 10,
                     "a position at rest")
            rig.send_signal(signal.SIGSTOP)
            try:
                wait_for(lambda: board.axes["rotor"].status().stale, 15, "stale said")
                silent = board.axes["rotor"].status()
                assert silent.position_rad is not None, "the last one known"
                status = {a["name"]: a for a in board.status()["axes"]}
                assert status["rotor"]["rest"]["stale"] and status["rotor"]["rest"]["errors"] > 0
            finally:
                rig.send_signal(signal.SIGCONT)
            wait_for(lambda: not board.axes["rotor"].status().stale, 15, "answering again")
    finally:
        process.terminate()
        process.wait(10)
        rig.terminate()
        rig.wait(10)


def test_a_follower_whose_socket_fails_says_so_and_follows_again(board_address):
    with Board(board_address) as board:
        follower = board.follower
        assert follower.wait_until_heard(10).reachable
        seen = []
        follower.listen(seen.append)

        class Failing:
            """The follower's socket, closed under it: whatever the follower
            calls next (a poll, or the receive after a poll it began on the
            real socket) fails as a closed ZeroMQ socket does."""
            def __init__(self, real):
                self.real = real

            def __getattr__(self, _name):
                def fail(*_args, **_kwargs):
                    self.real.close()
                    raise zmq.ZMQError(zmq.ENOTSOCK)
                return fail

            def close(self):
                pass

        follower._sub = Failing(follower._sub)
        wait_for(lambda: any(not s.reachable for s in seen), 5, "unreachable said")
        down = next(s for s in seen if not s.reachable)
        assert "ZMQError" in down.problem
        wait_for(lambda: follower.snapshot.reachable, 10, "followed again")
        assert board.axes["rotor"].status().position_rad is not None
        with board.run(V0=40, f=10, duration=0.3) as run:
            summary = run.wait()
        assert len(run.sensor) == summary["samples"]["sensor"]


def test_malformed_and_unexpected_messages_are_dropped_and_counted(board_address):
    link = Link(board_address)
    try:
        with Board(link.address) as board:
            follower = board.follower
            assert follower.wait_until_heard(10).reachable
            assert follower.wait_for_stream(5)
            time.sleep(0.3)  # the injected publisher's subscription reaches it
            before = follower.snapshot.rejected_frames
            link.put(b"sensor", b"PZSB not a frame")
            link.put(b"health", b"\xc1")  # never valid MessagePack
            link.put(b"state", msgpack.packb([1, 2, 3]))
            link.put(b"health", msgpack.packb({"board_ns": 1}))  # no state: not a health event
            link.put(b"gossip", b"{}")
            link.put(b"three", b"parts", b"here")
            wait_for(lambda: follower.snapshot.rejected_frames >= before + 6, 5,
                     "every bad message counted")
            assert follower.snapshot.reachable
            with board.run(V0=40, f=10, duration=0.3) as run:
                summary = run.wait()
            assert len(run.sensor) == summary["samples"]["sensor"]
    finally:
        link.close()


def test_a_board_that_goes_away_is_unreachable_then_followed_again(board_address):
    link = Link(board_address)
    try:
        with Board(link.address, timeout=0.5) as board:
            follower = board.follower
            assert follower.wait_until_heard(10).reachable
            link.down()
            wait_for(lambda: not follower.snapshot.reachable, 10, "unreachable said")
            assert follower.snapshot.problem
            with pytest.raises(NoReply):
                board.axes["rotor"].status()
            link.up()
            wait_for(lambda: follower.snapshot.reachable, 15, "followed again")
            assert board.axes["rotor"].status().position_rad is not None
    finally:
        link.close()
