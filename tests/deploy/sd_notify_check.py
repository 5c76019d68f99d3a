#!/usr/bin/env python3
"""piezod speaks systemd's notify protocol (Type=notify, WatchdogSec): this
plays the service manager. It binds the NOTIFY_SOCKET datagram socket,
starts piezod with WATCHDOG_USEC, and checks READY=1, then watchdog pings
at about half the period, then STOPPING=1 on SIGTERM; a stopped (hung)
piezod sends no ping. Usage: sd_notify_check.py PIEZOD CONFIG PORT"""
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import peers  # noqa: E402

piezod, config, port = sys.argv[1], sys.argv[2], sys.argv[3]
watchdog_s = 0.4

with tempfile.TemporaryDirectory() as tmp:
    path = os.path.join(tmp, "notify")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(path)
    sock.settimeout(10)
    env = dict(os.environ, NOTIFY_SOCKET=path, WATCHDOG_USEC=str(int(watchdog_s * 1e6)))
    daemon = peers.spawn(
        [piezod, "--config", config, "--listen", f"tcp://127.0.0.1:{port}"],
        env=env, stderr=subprocess.DEVNULL)

    def receive(timeout):
        sock.settimeout(timeout)
        try:
            return sock.recv(4096).decode()
        except socket.timeout:
            return None

    failures = []
    first = receive(10)
    if first is None or "READY=1" not in first:
        failures.append(f"first message {first!r}, expected READY=1")
    pings = []
    start = time.monotonic()
    while time.monotonic() - start < 2.0:
        m = receive(1.0)
        if m and "WATCHDOG=1" in m:
            pings.append(time.monotonic())
    gaps = [b - a for a, b in zip(pings, pings[1:])]
    print(f"{len(pings)} watchdog pings in 2 s, largest gap {max(gaps, default=0):.3f} s "
          f"(WatchdogSec {watchdog_s} s)")
    if len(pings) < 3 or max(gaps, default=99) >= watchdog_s:
        failures.append("pings missing or later than the watchdog period")

    # A hung daemon (stopped here) pings no more: systemd would restart it.
    daemon.send_signal(signal.SIGSTOP)
    while receive(0.05) is not None:
        pass
    hung = receive(2 * watchdog_s)
    print(f"while stopped: {hung!r}")
    if hung is not None:
        failures.append(f"a stopped daemon still notified {hung!r}")
    daemon.send_signal(signal.SIGCONT)

    daemon.send_signal(signal.SIGTERM)
    seen_stopping = False
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not seen_stopping:
        m = receive(1.0)
        seen_stopping = bool(m and "STOPPING=1" in m)
    rc = daemon.wait(10)
    if not seen_stopping:
        failures.append("no STOPPING=1 on SIGTERM")
    if rc != 0:
        failures.append(f"exit code {rc} on SIGTERM")

for f in failures:
    print("FAIL:", f)
print("sd_notify: ok" if not failures else "sd_notify: failed")
sys.exit(1 if failures else 0)
