"""A board of three axes (configs/three-axes.toml) through piezo_rig.board
and a real piezod: the board lists its axes with their own geometry and
limits, each axis runs and moves on its own with its own zero, and a
request that names no axis, or one the board lacks, is refused before
anything moves."""

import os

import numpy as np
import pytest

import peers
from piezo_rig import errors
from piezo_rig.board import Board


@pytest.fixture(scope="module")
def board_address(tmp_path_factory, source):
    where = tmp_path_factory.mktemp("axes")
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(where / "piezod.err"), sets=[f"piezod.calibration_file={where / 'calibration.json'}"])
    yield address
    process.terminate()
    process.wait(10)


@pytest.fixture
def board(board_address):
    with Board(board_address) as b:
        if b.status()["state"] == "fault":
            b.reset_fault()
        yield b


def test_hello_lists_every_axis_with_its_geometry_and_limits(board):
    axes = board.hello()["axes"]
    assert [a["name"] for a in axes] == ["theta", "phi", "chi"]
    assert list(board.axes) == ["theta", "phi", "chi"]
    assert axes[1]["r2_m"] == 0.08 and axes[0]["r2_m"] == 0.062
    assert axes[2]["V_max"] == 60.0 and axes[0]["V_max"] == 80.0
    assert axes[2]["travel_min_rad"] == -0.5 and axes[2]["travel_max_rad"] == 0.5
    assert axes[0]["travel_max_rad"] is None
    described = {a["name"]: a for a in board.arguments("move_to")}
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
    assert phi.axis == "phi" and phi.r2_m == 0.08
    assert board.status()["run"]["axis"] == "phi"
    theta_phi = phi.theta()
    assert np.nanmax(theta_phi) > 1e-3  # 60 V, 10 Hz, five periods: forward
    positions = {a["name"]: a for a in board.status()["axes"]}
    # phi's position is its own sensor's over its own radius, from its zero:
    # the mean of its last 8 good readings, as for a board of one.
    good = theta_phi[~np.isnan(theta_phi)]
    assert positions["phi"]["position"]["position_rad"] == pytest.approx(np.mean(good[-8:]),
                                                                          abs=1e-9)
    # theta and chi have not run: no readings, no position.
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
