"""piezo-tango with a Tango database, as a lab runs it: MariaDB and Tango's
database server (Debian's mariadb-server and tango-db) started here, the
devices registered with ``tango_admin`` by the very commands of
docs/tango.md ("With a database"), the server started as it says, and
Tango clients that find the devices through the database. Needs PyTango,
tango_admin, DataBaseds and mariadbd (scripts/setup.sh installs them):
without them this fails rather than skips."""

import os
import re
import shlex
import subprocess
import sys
import threading
import time

import pytest
import tango  # noqa: F401 -- a set-up without PyTango fails here
from tango import AttrQuality, DevState

import peers
from piezo_rig.board import Board

DATABASE_SERVER = "/usr/lib/tango/DataBaseds"
TANGO_DB_SCHEMA = "/usr/share/dbconfig-common/data/tango-db/install/mysql"


def wait_for(condition, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"{what}: not within {seconds} s")


def run(command, **kw):
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, **kw)
    assert done.returncode == 0, f"{command}: {done.stderr}{done.stdout}"
    return done.stdout


@pytest.fixture(scope="module")
def tango_host(tmp_path_factory):
    """MariaDB and DataBaseds on loopback ports of their own: TANGO_HOST."""
    where = tmp_path_factory.mktemp("tango-db")
    data, sock = where / "data", where / "mariadb.sock"
    run(["mariadb-install-db", "--no-defaults", f"--datadir={data}",
         "--auth-root-authentication-method=normal"])
    sql_port = peers.free_port()
    mariadb = peers.spawn(["mariadbd", "--no-defaults", f"--datadir={data}", f"--socket={sock}",
                           f"--port={sql_port}", "--bind-address=127.0.0.1", "--user=root"],
                          stdout=subprocess.DEVNULL, stderr=open(where / "mariadb.err", "w"))
    client = ["mariadb", f"--socket={sock}", "-u", "root"]
    wait_for(lambda: subprocess.run(client + ["-e", "SELECT 1"], capture_output=True)
             .returncode == 0, 30, "MariaDB up")
    run(client + ["-e", "CREATE DATABASE tango; CREATE USER 'tango'@'127.0.0.1' IDENTIFIED BY "
                  "'tango'; GRANT ALL ON tango.* TO 'tango'@'127.0.0.1';"])
    with open(TANGO_DB_SCHEMA) as schema:
        run(client + ["tango"], stdin=schema)
    port = peers.free_port()
    env = dict(os.environ, MYSQL_HOST=f"127.0.0.1:{sql_port}", MYSQL_USER="tango",
               MYSQL_PASSWORD="tango", MYSQL_DATABASE="tango")
    databaseds = peers.spawn([DATABASE_SERVER, "2", "-ORBendPoint", f"giop:tcp:127.0.0.1:{port}"],
                             env=env, stdout=subprocess.DEVNULL,
                             stderr=open(where / "databaseds.err", "w"))
    host = f"127.0.0.1:{port}"
    wait_for(lambda: subprocess.run(["tango_admin", "--ping-database"], capture_output=True,
                                    env=dict(os.environ, TANGO_HOST=host)).returncode == 0,
             30, "the Tango database up")
    yield host
    for p in (databaseds, mariadb):
        p.terminate()
        p.wait(30)


def documented_commands(source):
    """The shell lines of docs/tango.md's "With a database" section."""
    text = open(os.path.join(source, "docs", "tango.md")).read()
    section = text.split("### With a database", 1)[1].split("\n### ", 1)[0]
    return [line.strip() for line in section.splitlines()
            if line.startswith("    ") and line.strip().split()[0] in ("tango_admin", "piezo-tango")]


@pytest.fixture(scope="module")
def lab(tango_host, tmp_path_factory, source):
    """A board of three axes, registered and served as docs/tango.md says."""
    where = tmp_path_factory.mktemp("tango-lab")
    board, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(where / "piezod.err"), sets=["run.clock=realtime"])  # read at rest, as a rig is
    env = dict(os.environ, TANGO_HOST=tango_host)
    commands = documented_commands(source)
    assert [c.split()[0] for c in commands].count("tango_admin") >= 4, commands
    server = None
    for line in commands:
        words = [w.replace("tcp://127.0.0.1:5555", address) for w in shlex.split(line)]
        if words[0] == "tango_admin":
            run(words, env=env)
        else:  # piezo-tango lab: the project's server, from this build
            # phi may be re-targeted mid-move (a device property, set as any other).
            run(["tango_admin", "--add-property", "piezo/lab/phi", "allow_retarget", "true"],
                env=env)
            started = time.monotonic()
            server = peers.spawn([sys.executable, "-m", "piezo_rig.tango_server", *words[1:]],
                                 env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                 text=True)
            for out in server.stdout:
                if "Ready to accept request" in out:
                    break
            assert server.poll() is None, "piezo-tango ended at its start"
            threading.Thread(target=server.stdout.read, daemon=True).start()
    assert server is not None, "docs/tango.md starts the server"
    yield {"tango_host": tango_host, "address": address, "started": started}
    server.terminate()
    server.wait(30)
    board.terminate()
    board.wait(10)


def device(lab, name):
    return tango.DeviceProxy(f"tango://{lab['tango_host']}/{name}")


def test_the_registered_devices_show_each_axis_position_at_once(lab):
    theta, phi = device(lab, "piezo/lab/theta"), device(lab, "piezo/lab/phi")
    for axis in (theta, phi):
        # A board started just now: its first readings at rest, then a number.
        wait_for(lambda: axis.read_attribute("Position").quality == AttrQuality.ATTR_VALID, 10,
                 "a number before any move")
        assert abs(axis.read_attribute("Position").value) < 1e-4
    print(f"Position VALID {time.monotonic() - lab['started']:.2f} s after piezo-tango was "
          "started")
    board = device(lab, "piezo/lab/board")
    assert "theta" in board.read_attribute("Axes").value


def test_a_write_in_progress_does_not_hold_up_another_clients_reads(lab):
    writer, reader = device(lab, "piezo/lab/theta"), device(lab, "piezo/lab/theta")
    wait_for(lambda: writer.state() == DevState.ON, 10, "theta idle")
    start = reader.read_attribute("Position").value
    target = start + 0.02
    began = time.monotonic()
    writer.write_attribute("Position", target)
    wrote_s = time.monotonic() - began
    readings, slowest = [], 0.0
    while reader.state() == DevState.MOVING or not readings:
        t = time.monotonic()
        r = reader.read_attribute("Position")
        slowest = max(slowest, time.monotonic() - t)
        readings.append((r.value, r.quality))
        if time.monotonic() - began > 60:
            break
    print(f"the write returned in {wrote_s * 1e3:.0f} ms; {len(readings)} reads of another "
          f"client during the move, the slowest {slowest * 1e3:.0f} ms")
    changing = [v for v, q in readings if q == AttrQuality.ATTR_CHANGING]
    assert len(changing) >= 3, "the other client read the move as it happened"
    assert len(set(changing)) >= 2, "the angles it read changed"
    wait_for(lambda: reader.state() == DevState.ON, 30, "on target")
    with Board(lab["address"]) as board:
        status = {a["name"]: a for a in board.status()["axes"]}
        assert status["theta"]["position"]["position_rad"] == pytest.approx(target, abs=1e-3)


def test_a_retarget_mid_move_returns_at_once_and_ends_at_the_new_target(lab):
    phi = device(lab, "piezo/lab/phi")
    wait_for(lambda: phi.read_attribute("Position").quality == AttrQuality.ATTR_VALID, 10,
             "phi at rest")
    wait_for(lambda: phi.state() == DevState.ON, 10, "phi idle")
    start = phi.read_attribute("Position").value
    phi.write_attribute("Position", start + 0.05)
    assert phi.state() == DevState.MOVING
    began = time.monotonic()
    phi.write_attribute("Position", start + 0.01)  # allow_retarget: the move is re-targeted
    print(f"the re-targeting write returned in {(time.monotonic() - began) * 1e3:.0f} ms")
    wait_for(lambda: phi.state() == DevState.ON, 60, "on the new target")
    with Board(lab["address"]) as board:
        status = {a["name"]: a for a in board.status()["axes"]}
        assert status["phi"]["position"]["position_rad"] == pytest.approx(start + 0.01, abs=1e-3)
        assert status["theta"]["fault"] is None and status["phi"]["fault"] is None
