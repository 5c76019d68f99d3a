"""Helpers shared by the Python tests that start real peers (piezod,
rig-sim) on loopback."""

import socket
import time


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


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_piezod(piezod, config, err_path, tries=5):
    """Starts piezod on a free port (its stream on the next one) and waits
    until it listens; a port taken by another process meanwhile (a busy
    machine runs many tests) makes it exit, and it is started again on
    another. Returns (process, address); raises with its stderr if it never
    listens."""
    import subprocess

    for _ in range(tries):
        port = free_port()
        while port >= 65534:
            port = free_port()
        board = subprocess.Popen([piezod, "--config", config, "--listen", f"tcp://127.0.0.1:{port}"],
                                 stderr=open(err_path, "w"))
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
