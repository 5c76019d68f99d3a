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
