"""Helpers shared by the Python tests that start real peers (piezod,
rig-sim) on loopback."""

import ctypes
import random
import signal
import socket
import subprocess
import time

_PR_SET_PDEATHSIG = 1


def _die_with_parent():
    # Runs in the child between fork and exec: the kernel sends SIGKILL when
    # the test that started it ends, however it ends (a failed check, an
    # exception, CTest's timeout killing it), so no helper outlives its test.
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)


def spawn(argv, **popen_args):
    """subprocess.Popen for a test's helper (piezod, piezo, a proxy): the
    helper is killed by the kernel when the test's process ends, on every
    exit path, the ones no ``finally`` reaches included."""
    return subprocess.Popen(argv, preexec_fn=_die_with_parent, **popen_args)


def wait_for_tcp(port, seconds=20):
    """True once something accepts connections on 127.0.0.1:port."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            return True
        except OSError:
            time.sleep(0.05)
    return False


def _ephemeral_start():
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def _bindable(port):
    try:
        socket.create_server(("127.0.0.1", port)).close()
        return True
    except OSError:
        return False


def free_port(count=1):
    """A port P on loopback with P .. P + count - 1 free (piezod takes two:
    its commands on P, its stream on P + 1).

    Chosen below the kernel's ephemeral range: the outgoing connections of
    every other test on a busy machine take their local ports from that range
    (even ones first, right beside the odd ones bind(0) hands out), and one
    can take a port between this check and the listener's bind. Below it, only
    another listener can, and it would have to pick the same random port."""
    top = _ephemeral_start() - count
    while True:
        port = random.randrange(10000, top)
        if all(_bindable(port + i) for i in range(count)):
            return port


def start_piezod(piezod, config, err_path, tries=5, sets=()):
    """Starts piezod on a free port (its stream on the next one) and waits
    until it listens; a port taken by another process meanwhile (a busy
    machine runs many tests) makes it exit, and it is started again on
    another. `sets`: SECTION.KEY=VALUE overrides of the config. Returns
    (process, address); raises with its stderr if it never listens."""
    for _ in range(tries):
        port = free_port(2)
        overrides = [arg for key in sets for arg in ("--set", key)]
        board = spawn([piezod, "--config", config, "--listen", f"tcp://127.0.0.1:{port}",
                       *overrides], stderr=open(err_path, "w"))
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and board.poll() is None:
            with socket.socket() as probe:
                if probe.connect_ex(("127.0.0.1", port)) == 0:
                    return board, f"tcp://127.0.0.1:{port}"
            time.sleep(0.05)
        if board.poll() is None:
            board.kill()
        board.wait()
    with open(err_path) as f:
        raise RuntimeError("piezod never listened: " + f.read())


def restart_piezod(piezod, config, err_path, address, sets=()):
    """Starts piezod again on ``address`` (a board that comes back on its
    port, as after a reboot) and waits until it listens."""
    port = int(address.rpartition(":")[2])
    overrides = [arg for key in sets for arg in ("--set", key)]
    board = spawn([piezod, "--config", config, "--listen", address, *overrides],
                  stderr=open(err_path, "a"))
    if not wait_for_tcp(port, 30):
        board.kill()
        with open(err_path) as f:
            raise RuntimeError(f"piezod did not come back on {address}: " + f.read())
    return board
