"""Fixtures of the Python package's tests: the built `piezo` and `piezod`
(CTest passes their paths), the source tree, and a real piezod on the
simulated rig on a free loopback port."""

import json
import os
import subprocess
import sys

import pytest

SOURCE = os.environ.get("PIEZO_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(SOURCE, "tests", "support"))
import peers  # noqa: E402


@pytest.fixture(scope="session")
def piezo():
    """Runs the `piezo` CLI; returns its stdout parsed as JSON."""
    binary = os.environ["PIEZO_BINARY"]

    def run(*args, cwd=None):
        out = subprocess.run([binary, *args], capture_output=True, text=True, cwd=cwd)
        if out.returncode != 0:
            raise RuntimeError(f"piezo {' '.join(args)}: {out.stderr}")
        return json.loads(out.stdout) if "--json" in args else out.stdout

    run.binary = binary
    return run


@pytest.fixture(scope="session")
def source():
    return SOURCE


def start_board(tmp_path, *extra_sets):
    config = tmp_path / "piezod.toml"
    with open(os.path.join(SOURCE, "configs", "piezod-sim.toml")) as f:
        text = f.read()
    config.write_text(text + "".join(extra_sets))
    return peers.start_piezod(os.environ["PIEZOD_BINARY"], str(config), str(tmp_path / "piezod.err"))


@pytest.fixture
def board(board_address):
    """A client of the module's board (`board_address`), its fault cleared."""
    from piezo_rig.board import Board
    with Board(board_address) as b:
        if b.status()["state"] == "fault":
            b.reset_fault()
        yield b


@pytest.fixture(scope="module")
def board_address(tmp_path_factory):
    process, address = start_board(tmp_path_factory.mktemp("board"))
    yield address
    process.terminate()
    process.wait(10)
